"""The real ROS 2 node of the ROS 2 benchmark: rclpy from PyPI's ROS 2 wheels (build/ros-<release>/venv).

`python ros2_rclpy_node.py rate NAMESPACE SECONDS`: counts joint_states for SECONDS (after the first);
`python ros2_rclpy_node.py latency NAMESPACE COUNT`: publishes COUNT velocity_commands, each a
different speed, and prints when each was published (wall clock, ns), keyed by its wire value
(0.1 RPM). Prints one JSON object. Run by ros2_bench.py, which does the rest.
"""

# mypy: ignore-errors
import json
import math
import random
import sys
import time

import rclpy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray


def main() -> None:
    mode, ns, amount = sys.argv[1], sys.argv[2], float(sys.argv[3])
    rclpy.init()
    node = rclpy.create_node("bench")
    received: list[float] = []
    node.create_subscription(JointState, f"{ns}/joint_states", lambda m: received.append(time.monotonic()), 10)
    deadline = time.monotonic() + 15
    while not received and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.01)
    out: dict[str, object] = {}
    if mode == "rate":
        end = time.monotonic() + 0.5  # warm up
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.001)
        before, start = len(received), time.monotonic()
        while time.monotonic() - start < amount:
            rclpy.spin_once(node, timeout_sec=0.001)
        out = {"received": len(received) - before, "seconds": time.monotonic() - start}
    else:
        publisher = node.create_publisher(Float64MultiArray, f"{ns}/velocity_commands", 10)
        end = time.monotonic() + 0.5  # let discovery match the writer
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.01)
        sent = {}
        for k in range(int(amount)):
            rpm = 10.0 + 0.1 * (k % 2000)
            sent[round(rpm * 10)] = time.time_ns()
            publisher.publish(Float64MultiArray(data=[rpm * 2 * math.pi / 60]))
            rclpy.spin_once(node, timeout_sec=random.uniform(0.005, 0.015))
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.01)
        out = {"sent": sent}
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps(out))


if __name__ == "__main__":
    main()
