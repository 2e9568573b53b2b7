"""A real ROS 2 node (rclpy from PyPI's ROS 2 wheels) playing a user's part against `nurimc ros2`.

Runs in build/ros-<release>/venv, not in nurimc's venv: `python probe.py arm NAMESPACE` or
`python probe.py base NAMESPACE`. It only acts and records; it prints one JSON object with what it
saw, and the pytest side (test_rclpy.py) judges it.
"""

# This file runs under the ROS 2 wheels' interpreter; nurimc's type checker does not see rclpy.
# mypy: ignore-errors
import functools
import json
import math
import os
import statistics
import sys
import time

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray


class Probe:
    def __init__(self, namespace: str) -> None:
        rclpy.init()
        self.node = rclpy.create_node("probe")
        self.ns = namespace
        self.states: list[tuple[float, JointState]] = []
        self.node.create_subscription(JointState, f"{namespace}/joint_states", self._state, 10)

    def _state(self, message: JointState) -> None:
        self.states.append((time.monotonic(), message))

    def spin(self, seconds: float, until=None, every=None) -> bool:
        """Spin up to `seconds`; stop early when until() is true; call every() each 50 ms."""
        end = time.monotonic() + seconds
        next_call = time.monotonic()
        while time.monotonic() < end:
            if every is not None and time.monotonic() >= next_call:
                every()
                next_call += 0.05
            rclpy.spin_once(self.node, timeout_sec=0.01)
            if until is not None and until():
                return True
        return until is None

    def last(self) -> JointState:
        return self.states[-1][1]

    def graph(self) -> dict:
        names = [list(pair) for pair in self.node.get_node_names_and_namespaces()]
        infos = self.node.get_publishers_info_by_topic(f"{self.ns}/joint_states")
        pubs = [(i.node_name, i.node_namespace) for i in infos]
        hashes = sorted({str(i.topic_type_hash) for i in infos})
        subs = [
            (i.node_name, i.node_namespace)
            for i in self.node.get_subscriptions_info_by_topic(f"{self.ns}/position_commands")
        ]
        try:
            by_node = sorted(name for name, _ in self.node.get_publisher_names_and_types_by_node("nurimc", self.ns))
        except Exception as error:  # the node not (yet) in the graph: rclpy raises NodeNameNonExistentError
            by_node = [f"error: {error}"]
        return {
            "nodes": names,
            "publishers_by_node": by_node,
            "joint_states_publishers": pubs,
            "joint_states_type_hashes": hashes,
            "position_commands_subscribers": subs,
        }


def arm(probe: Probe) -> dict:
    """Joints 0 and 1: joint_states, the graph, π/2, ros2_control's topics, 2 rad/s, estop, diagnostics."""
    node, ns, out = probe.node, probe.ns, {}
    positions = node.create_publisher(Float64MultiArray, f"{ns}/position_commands", 10)
    velocities = node.create_publisher(Float64MultiArray, f"{ns}/velocity_commands", 10)
    estop = node.create_publisher(Bool, f"{ns}/estop", 10)
    control = node.create_publisher(JointState, "/robot_joint_commands", 1)  # as the interface: QoS depth 1
    control_states: list[JointState] = []
    node.create_subscription(JointState, "/robot_joint_states", control_states.append, qos_profile_sensor_data)
    diagnostics: list[DiagnosticArray] = []
    node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)

    probe.spin(15, until=lambda: len(probe.states) > 0)
    start = len(probe.states)
    probe.spin(2.0)
    out["joint_states_rate"] = (len(probe.states) - start) / 2.0
    out["names"] = list(probe.last().name)
    probe.spin(3, until=lambda: any(n == "nurimc" for n, _ in probe.node.get_node_names_and_namespaces()))
    probe.spin(0.5)
    out["graph"] = probe.graph()

    def at(index: int, target: float, tolerance: float = 0.002):
        return lambda: abs(probe.last().position[index] - target) <= tolerance

    sent = time.monotonic()
    positions.publish(Float64MultiArray(data=[math.pi / 2, 0.0]))
    out["position_reached"] = probe.spin(8, until=at(0, math.pi / 2))
    out["position_seconds"] = time.monotonic() - sent
    out["position"] = probe.last().position[0]

    # ros2_control's topic-based interface: one JointState naming the joints, position for joint 0...
    names = out["names"]
    control.publish(JointState(name=[names[0]], position=[-math.pi / 2]))
    out["control_position_reached"] = probe.spin(8, until=at(0, -math.pi / 2))
    # ... and velocity for joint 1, published each cycle as a controller manager does (20 Hz here)
    mark = len(probe.states)
    out["control_velocity_reached"] = probe.spin(
        5,
        until=lambda: abs(probe.last().velocity[1] - 1.5) <= 0.05,
        every=lambda: control.publish(JointState(name=[names[1]], velocity=[1.5])),
    )
    probe.spin(0.5, every=lambda: control.publish(JointState(name=[names[1]], velocity=[1.5])))
    out["control_velocity"] = statistics.median(m.velocity[1] for _, m in probe.states[-8:])
    out["control_velocity_advanced"] = probe.last().position[1] - probe.states[mark][1].position[1]
    out["control_states_received"] = len(control_states)
    out["control_states_names"] = list(control_states[-1].name) if control_states else []
    out["control_stop"] = probe.spin(
        3,
        until=lambda: probe.last().velocity[1] == 0.0,
        every=lambda: control.publish(JointState(name=[names[1]], velocity=[0.0])),
    )

    # velocity_commands: joint 1 at 2 rad/s (published at 20 Hz, as a controller does)
    turn = lambda: velocities.publish(Float64MultiArray(data=[0.0, 2.0]))  # noqa: E731
    out["velocity_reached"] = probe.spin(5, until=lambda: abs(probe.last().velocity[1] - 2.0) <= 0.05, every=turn)
    begin = len(probe.states)
    probe.spin(1.0, every=turn)
    window = [m.velocity[1] for _, m in probe.states[begin:]]
    out["velocity_median"] = statistics.median(window) if window else None
    out["velocity_advanced"] = probe.last().position[1] - probe.states[begin][1].position[1] if window else 0.0

    estop.publish(Bool(data=True))
    out["estop_stopped"] = probe.spin(3, until=lambda: all(v == 0.0 for v in probe.last().velocity))
    held = probe.last().position[1]
    probe.spin(0.5, every=turn)  # refused while latched
    out["estop_drift"] = abs(probe.last().position[1] - held)
    out["estop_velocities"] = list(probe.last().velocity)

    probe.spin(3, until=lambda: any(any(ns[1:] in s.name for s in d.status) for d in diagnostics))
    ours = [s for d in diagnostics for s in d.status if ns[1:] in s.name]
    out["diagnostics"] = sorted({s.name.split(": ")[-1] for s in ours})
    bus = [s for s in ours if s.name.endswith(": bus")]
    out["diagnostics_bus"] = {kv.key: kv.value for kv in bus[-1].values} if bus else {}
    return out


def base(probe: Probe) -> dict:
    """A 1 m square on cmd_vel, closed on odom; records odom and the wheels' joint_states."""
    node, ns, out = probe.node, probe.ns, {}
    cmd_vel = node.create_publisher(Twist, f"{ns}/cmd_vel", 10)
    odoms: list[Odometry] = []
    node.create_subscription(Odometry, f"{ns}/odom", odoms.append, 10)
    diagnostics: list[DiagnosticArray] = []
    node.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
    probe.spin(15, until=lambda: len(probe.states) > 0 and len(odoms) > 0)
    probe.spin(3, until=lambda: any(n == "nurimc" for n, _ in probe.node.get_node_names_and_namespaces()))
    out["graph"] = probe.graph()
    speed, rate = 0.5, 1.5  # m/s, rad/s; the bridge's limits: 1 m/s^2, 3 rad/s^2
    brake_distance, brake_angle = speed**2 / 2 / 1.0, rate**2 / 2 / 3.0
    command = Twist()

    def publish() -> None:
        cmd_vel.publish(command)

    def pose():
        p = odoms[-1].pose.pose
        return p.position.x, p.position.y, 2 * math.atan2(p.orientation.z, p.orientation.w)

    def still() -> bool:
        t = odoms[-1].twist.twist
        return abs(t.linear.x) < 1e-3 and abs(t.angular.z) < 1e-3

    first = len(probe.states)
    out["start"] = pose()

    def drive(until, linear: float, angular: float) -> None:
        command.linear.x, command.angular.z = linear, angular
        probe.spin(6, until=until, every=publish)

    for side in range(4):  # each side and corner: fast, then slow for the last part, then stop
        x0, y0, _yaw = pose()
        gone = functools.partial(lambda x, y: math.hypot(pose()[0] - x, pose()[1] - y), x0, y0)
        drive(functools.partial(lambda g: g() >= 1.0 - 1.5 * brake_distance, gone), speed, 0.0)
        drive(functools.partial(lambda g: g() >= 1.0 - 0.005, gone), 0.1, 0.0)
        drive(still, 0.0, 0.0)
        # the heading this corner should end at, from the start
        turned = functools.partial(lambda y: math.remainder(pose()[2] - y, 2 * math.pi), math.pi / 2 * side)
        drive(functools.partial(lambda t: t() >= math.pi / 2 - 1.5 * brake_angle, turned), 0.0, rate)
        drive(functools.partial(lambda t: t() >= math.pi / 2 - 0.01, turned), 0.0, 0.3)
        drive(still, 0.0, 0.0)
    probe.spin(0.5)
    out["end"] = pose()
    out["odom_count"] = len(odoms)
    out["frames"] = [odoms[-1].header.frame_id, odoms[-1].child_frame_id]
    out["max_speed"] = max(abs(o.twist.twist.linear.x) for o in odoms)
    out["covariance_diagonal"] = [odoms[-1].pose.covariance[i * 7] for i in range(6)]
    out["wheels"] = [list(m.position) for _, m in probe.states[first:]]
    out["names"] = list(probe.last().name)
    # the command timeout: drive, then go silent; the base decelerates to a stop (never released)
    command.linear.x = speed
    probe.spin(1.0, every=publish)
    stopped_at = time.monotonic()
    probe.spin(4, until=still)
    out["timeout_stop_seconds"] = time.monotonic() - stopped_at
    speeds = [abs(o.twist.twist.linear.x) for o in odoms[-40:]]
    out["timeout_speeds"] = speeds
    base_statuses = [st for d in diagnostics for st in d.status if st.name == f"nurimc{ns}: base"]
    out["base_status"] = {kv.key: kv.value for kv in base_statuses[-1].values} if base_statuses else {}
    return out


def restart(probe: Probe) -> dict:
    """A node that outlives two bridges: as soon as each one's joint_states arrive, one position
    command (published once, as a user's node does it); the time from the command to the joint there.
    Says "phase <n> done" on stdout after each, and "bridge gone" when the first one's joint_states
    have stopped, so the test can restart the bridge."""
    node, ns, out = probe.node, probe.ns, {"reach_s": []}
    positions = node.create_publisher(Float64MultiArray, f"{ns}/position_commands", 10)
    for phase, target in enumerate((math.pi / 4, math.pi / 4)):  # each bridge's simulated motor starts at 0
        count = len(probe.states)
        if not probe.spin(60, until=lambda count=count: len(probe.states) > count):
            out["reach_s"].append(None)
            break
        if phase == 1 and os.environ.get("PROBE_NEW_WRITER"):  # a writer whose first sample this is
            positions = node.create_publisher(Float64MultiArray, f"{ns}/position_commands", 10)
            probe.spin(1.0, until=lambda p=positions: p.get_subscription_count() > 0)
        sent = time.monotonic()
        out.setdefault("matched_at_publish", []).append(positions.get_subscription_count())
        positions.publish(Float64MultiArray(data=[target]))
        reached = probe.spin(10, until=lambda target=target: abs(probe.last().position[0] - target) <= 0.002)
        out["reach_s"].append(round(time.monotonic() - sent, 3) if reached else None)
        print(f"phase {phase} done", flush=True)
        if phase == 0:  # until that bridge is gone: no joint_states for 0.5 s
            while True:
                count = len(probe.states)
                probe.spin(0.5)
                if len(probe.states) == count:
                    break
            # its reader unmatched by its goodbye (not 10 s later by its lease running out)
            probe.spin(3, until=lambda p=positions: p.get_subscription_count() == 0)
            out["matched_when_gone"] = positions.get_subscription_count()
            print("bridge gone", flush=True)
    # the new bridge's reader alone (a handshake reader stays a moment: ros2/handshake.py)
    probe.spin(6, until=lambda: positions.get_subscription_count() == 1)
    out["matched_after"] = positions.get_subscription_count()
    return out


def call(probe: Probe, service_type, name: str, request, timeout: float = 10.0):
    """One service call as a user's node makes it: wait for the service, call, spin until the answer."""
    client = probe.node.create_client(service_type, name)
    started = time.monotonic()
    if not client.wait_for_service(timeout_sec=15):
        return None, f"{name}: not available within 15 s"
    future = client.call_async(request)
    deadline = time.monotonic() + timeout
    while not future.done() and time.monotonic() < deadline:
        rclpy.spin_once(probe.node, timeout_sec=0.05)
    probe.node.destroy_client(client)
    if not future.done():
        return None, f"{name}: no answer within {timeout} s"
    return future.result(), round(time.monotonic() - started, 3)


def services(probe: Probe) -> dict:
    """The bridge's parameters (rcl_interfaces, as rclpy's parameter clients call them) and its estop
    service (std_srvs/Trigger): list, get, set in range, set out of range, a controller setting."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
    from std_srvs.srv import Trigger

    node_path = f"{probe.ns}/nurimc"
    out: dict = {}
    listed, out["list_time"] = call(probe, ListParameters, f"{node_path}/list_parameters", ListParameters.Request())
    out["names"] = list(listed.result.names) if listed else []
    got, _ = call(probe, GetParameters, f"{node_path}/get_parameters", GetParameters.Request(names=["rate", "ids"]))
    out["rate"] = got.values[0].double_value if got else None
    out["ids"] = list(got.values[1].integer_array_value) if got else None

    def set_one(name: str, value: ParameterValue):
        answer, _ = call(
            probe,
            SetParameters,
            f"{node_path}/set_parameters",
            SetParameters.Request(parameters=[Parameter(name=name, value=value)]),
        )
        return (answer.results[0].successful, answer.results[0].reason) if answer else (None, "no answer")

    out["set_rate"] = set_one("rate", ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=25.0))
    got, _ = call(probe, GetParameters, f"{node_path}/get_parameters", GetParameters.Request(names=["rate"]))
    out["rate_after"] = got.values[0].double_value if got else None
    out["set_rate_too_high"] = set_one("rate", ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=1e9))
    got, _ = call(probe, GetParameters, f"{node_path}/get_parameters", GetParameters.Request(names=["rate"]))
    out["rate_after_refusal"] = got.values[0].double_value if got else None
    out["set_ids"] = set_one("ids", ParameterValue(type=ParameterType.PARAMETER_INTEGER_ARRAY, integer_array_value=[3]))
    described, _ = call(
        probe, DescribeParameters, f"{node_path}/describe_parameters", DescribeParameters.Request(names=["rate"])
    )
    if described:
        d = described.descriptors[0]
        out["rate_range"] = (
            [d.floating_point_range[0].from_value, d.floating_point_range[0].to_value]
            if d.floating_point_range
            else None
        )
    setting = "motor_1.position_kp"
    got, _ = call(probe, GetParameters, f"{node_path}/get_parameters", GetParameters.Request(names=[setting]))
    out["kp_before"] = got.values[0].integer_value if got else None
    out["set_kp"] = set_one(setting, ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=77))
    got, _ = call(probe, GetParameters, f"{node_path}/get_parameters", GetParameters.Request(names=[setting]))
    out["kp_after"] = got.values[0].integer_value if got else None
    out["kp_type"] = got.values[0].type if got else None
    stopped, out["estop_time"] = call(probe, Trigger, f"{node_path}/estop", Trigger.Request())
    out["estop"] = [stopped.success, stopped.message] if stopped else None
    return out


def main() -> None:
    scenario, namespace = sys.argv[1], sys.argv[2]
    probe = Probe(namespace)
    try:
        result = {"arm": arm, "base": base, "restart": restart, "services": services}[scenario](probe)
    finally:
        probe.node.destroy_node()
        rclpy.shutdown()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
