"""A real ROS 2 node (rclpy, Fast DDS) on a laptop that joins late: `python late.py NS1,NS2 [TARGET]`.

Prints one JSON line: per namespace, seconds until its first joint_states, and whether a position
command (published every 0.2 s until it shows) moved the joint to TARGET rad (default π/2).
"""

# This file runs under the ROS 2 wheels' interpreter; nurimc's type checker does not see rclpy.
# mypy: ignore-errors
import json
import math
import sys
import time

import rclpy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray


def main() -> None:
    namespaces = sys.argv[1].split(",")
    target = float(sys.argv[2]) if len(sys.argv) > 2 else math.pi / 2
    start = time.monotonic()
    rclpy.init()
    node = rclpy.create_node("laptop")
    last: dict = {}
    found: dict = dict.fromkeys(namespaces)

    def on_state(ns, message):
        last[ns] = message
        if found[ns] is None:
            found[ns] = round(time.monotonic() - start, 2)

    for ns in namespaces:
        node.create_subscription(JointState, f"{ns}/joint_states", lambda m, ns=ns: on_state(ns, m), 10)
    publishers = {ns: node.create_publisher(Float64MultiArray, f"{ns}/position_commands", 10) for ns in namespaces}
    while time.monotonic() - start < 20 and None in found.values():
        rclpy.spin_once(node, timeout_sec=0.05)
    moved = {}
    for ns in namespaces:
        moved[ns] = False
        deadline = time.monotonic() + 10
        next_send = 0.0
        while found[ns] is not None and time.monotonic() < deadline:
            if time.monotonic() >= next_send:
                publishers[ns].publish(Float64MultiArray(data=[target]))
                next_send = time.monotonic() + 0.2
            rclpy.spin_once(node, timeout_sec=0.05)
            if ns in last and abs(last[ns].position[0] - target) <= 0.002:
                moved[ns] = True
                break
    node.destroy_node()
    rclpy.shutdown()
    print(json.dumps({"found_after_s": found, "moved": moved}), flush=True)


if __name__ == "__main__":
    main()
