"""`nurimc ros2`: the bus as ROS 2 topics over DDS, without ROS 2 installed (see docs/ros2.md)."""

from __future__ import annotations

import math
import os
import signal
import sys
import threading
from pathlib import Path
from typing import Any

import typer

from ..drivers.sync import Bus
from ..errors import NurimcError
from .common import EXIT_DEVICE, FramePrinter, Options, err, fail, options, out, parse_ids
from .i18n import tr
from .motion import RAMP
from .ros2_limits import (
    COMMAND_TIMEOUT,
    MAX_ANGULAR,
    MAX_ANGULAR_ACCEL,
    MAX_LINEAR,
    MAX_LINEAR_ACCEL,
    MOVE_VELOCITY,
    RATE,
    SECONDS,
    WHEEL_RADIUS,
    WHEEL_SEPARATION,
)

EXTRA_HINT = "this command needs the ros2 extra: pip install 'nurimc[ros2]' (cyclonedds, mcap)"


def need_extra() -> None:
    try:
        import cyclonedds  # noqa: F401
        import mcap  # noqa: F401
    except ImportError:
        fail(EXTRA_HINT)


MCAP_HINT = "writing MCAP needs the mcap package: pip install 'nurimc[record]' (or: pip install mcap)"


def need_mcap() -> None:
    """`record` and `repair-mcap` write MCAP with recording/cdr.py: the mcap package, no DDS stack."""
    try:
        import mcap  # noqa: F401
    except ImportError:
        fail(MCAP_HINT)


def open_traced_bus(o: Options, recorder: Any | None, reconnect: bool = True) -> Bus:
    """Like common.open_bus, with an MCAP recorder (and -v's printer) seeing every byte."""
    port = o.port or os.environ.get("NURIMC_PORT")
    if not port:
        fail("no port: give --port (e.g. /dev/ttyUSB0, socket://host:port, sim://?ids=1,2) or set NURIMC_PORT")
    tracers = [t for t in (recorder, FramePrinter() if o.verbose else None) if t is not None]
    tracer = tracers[0] if len(tracers) == 1 else _Tee(tracers) if tracers else None
    from .attach import attached_bus

    shared = attached_bus(port, o.baud, tracer, o.command)  # another nurimc program holds it: attach
    if shared is not None:
        return shared
    bus = Bus.open(port, baudrate=o.baud, tracer=tracer, reconnect=reconnect)  # reopened when lost: outage.py
    warning = getattr(bus.transport, "warning", None)
    if warning:
        err.print(f"[yellow]warning:[/] {warning}", soft_wrap=True)
    return bus


class _Tee:
    def __init__(self, tracers: list[Any]) -> None:
        self.tracers = tracers

    def record(self, direction: str, data: bytes) -> None:
        for tracer in self.tracers:
            tracer.record(direction, data)

    def close(self) -> None:
        for tracer in self.tracers:
            tracer.close()


def motor_ids(o: Options, ids_text: str | None, bus: Bus) -> list[int]:
    """--ids (or the global --id), else the controllers that answer at the bus's rate."""
    ids = parse_ids(ids_text) if ids_text else o.ids
    if ids:
        if len(set(ids)) != len(ids):
            fail(f"--ids {ids_text}: an ID is given twice")
        if 255 in ids or min(ids) < 0:
            fail("--ids: IDs are 0..254")
        return ids
    from ..procedures.discovery import discover

    err.print(tr(f"no --ids: looking for controllers at {bus.baudrate} bps..."))
    found = bus.run(discover(bus.core, [bus.baudrate]))
    if not found:
        fail(
            f"no controller answers at {bus.baudrate} bps on {bus.transport.url}: check --baud "
            "(`nurimc scan` searches every rate) or give --ids",
            EXIT_DEVICE,
        )
    return sorted(f.id for f in found)


def install_stop_signals() -> threading.Event:
    """An event that SIGINT / SIGTERM set (from now on, instead of interrupting)."""
    stop = threading.Event()

    def on_signal(signum: int, frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    return stop


def wait_for_signal(stop: threading.Event, seconds: float | None, signalled: threading.Event | None = None) -> None:
    """Until SIGINT / SIGTERM (or `seconds`, if given), or `stop` is set (e.g. the bridge ended)."""
    signalled = signalled or install_stop_signals()

    def relay() -> None:
        signalled.wait()
        stop.set()

    threading.Thread(target=relay, daemon=True).start()
    stop.wait(seconds)


def ros2(
    ctx: typer.Context,
    ids: str = typer.Option(None, "--ids", help="Controller IDs in joint order: 1,2 (default: those found)."),
    namespace: str = typer.Option("/", "--namespace", "-n", help="ROS 2 namespace of the topics, e.g. /left_arm."),
    joint_names: str = typer.Option(None, "--joint-names", help="One name per ID: shoulder,elbow (motor_<ID>)."),
    rate: float = typer.Option(
        50.0, "--rate", help=f"joint_states per second ({RATE.allowed}); 0 = as fast as the bus allows.", parser=RATE
    ),
    command_timeout: float = typer.Option(
        0.5,
        "--command-timeout",
        help=f"Seconds without velocity_commands before a turning motor holds ({COMMAND_TIMEOUT.allowed}); 0 = off.",
        parser=COMMAND_TIMEOUT,
    ),
    move_velocity: float = typer.Option(
        round(2 * math.pi, 4),
        "--move-velocity",
        help=f"Speed of moves to position_commands ({MOVE_VELOCITY.allowed}; 6.28 = 60 RPM).",
        parser=MOVE_VELOCITY,
    ),
    ramp: float = typer.Option(
        0.1, "--ramp", help=f"Seconds to reach a commanded velocity ({RAMP.allowed}).", parser=RAMP
    ),
    broadcast_read: bool = typer.Option(
        False,
        "--broadcast-read",
        help="Read all motors with one broadcast request (writes staggered response times to the controllers).",
    ),
    mcap_path: Path = typer.Option(None, "--mcap", help="Also record joint states and every frame to this file."),
    seconds: float = typer.Option(
        None,
        "--seconds",
        help=f"Stop after this many seconds ({SECONDS.allowed}; default: until Ctrl-C).",
        parser=SECONDS,
    ),
    node_name: str = typer.Option("nurimc", "--node-name", help="Name of the bridge's node in the ROS 2 graph."),
    control_commands: str = typer.Option(
        "/robot_joint_commands",
        "--control-commands-topic",
        help="JointState commands of ros2_control's topic-based hardware interface (its joint_commands_topic).",
    ),
    control_states: str = typer.Option(
        "/robot_joint_states",
        "--control-states-topic",
        help="Where that interface reads joint states (its joint_states_topic).",
    ),
    diff_drive: str = typer.Option(
        None, "--diff-drive", help="Mobile base: LEFT_ID,RIGHT_ID wheel motors (cmd_vel in, odom and /tf out)."
    ),
    wheel_radius: float = typer.Option(
        None, "--wheel-radius", help="Wheel radius, m (with --diff-drive).", parser=WHEEL_RADIUS
    ),
    wheel_separation: float = typer.Option(
        None, "--wheel-separation", help="Distance between the wheels, m (with --diff-drive).", parser=WHEEL_SEPARATION
    ),
    left_inverted: bool = typer.Option(False, "--left-inverted", help="The left motor turns backwards for forward."),
    right_inverted: bool = typer.Option(False, "--right-inverted", help="The right motor turns backwards for forward."),
    max_linear: float = typer.Option(1.0, "--max-linear", help="Base speed limit, m/s.", parser=MAX_LINEAR),
    max_angular: float = typer.Option(2.0, "--max-angular", help="Base turn-rate limit, rad/s.", parser=MAX_ANGULAR),
    max_linear_accel: float = typer.Option(
        1.0, "--max-linear-accel", help="Base acceleration limit, m/s².", parser=MAX_LINEAR_ACCEL
    ),
    max_angular_accel: float = typer.Option(
        3.0, "--max-angular-accel", help="Base angular acceleration limit, rad/s².", parser=MAX_ANGULAR_ACCEL
    ),
    stamped: bool = typer.Option(
        False, "--cmd-vel-stamped", help="cmd_vel is geometry_msgs/TwistStamped (Jazzy's diff_drive_controller)."
    ),
    odom_frame: str = typer.Option("odom", "--odom-frame", help="Frame id of the odometry."),
    base_frame: str = typer.Option("base_link", "--base-frame", help="Frame id of the base."),
    no_odom_tf: bool = typer.Option(
        False, "--no-odom-tf", help="Publish odom but not the odom -> base transform on /tf (e.g. robot_localization)."
    ),
    frame_prefix: str = typer.Option(
        "", "--frame-prefix", help="Put before every frame id, e.g. robot1/ (two robots on one /tf)."
    ),
    torque_constants: str = typer.Option(
        None,
        "--torque-constants",
        help="N·m/A per joint in --ids order, e.g. 0.12,0.12: effort in N·m (default: amperes).",
    ),
    dds: str = typer.Option(
        "rtps",
        "--dds",
        help="DDS stack: rtps (ours, pure Python: topics, parameters, services) or cyclone (Cyclone DDS: topics only).",
    ),
) -> None:
    """Publish joint_states and /diagnostics; obey position_commands, velocity_commands and estop (ROS 2 over DDS).

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 ros2 --ids 1,2 --namespace /arm
    """
    o = options(ctx)
    need_extra()
    from ..ros2 import control_topics, diffdrive
    from ..ros2.bridge import Bridge
    from ..ros2.dds import domain_id
    from ..ros2.graph import node_name as check_node_name
    from ..ros2.names import NameError_, topic, topic_option
    from ..ros2.names import joint_names as make_joint_names
    from ..ros2.names import namespace as check_namespace
    from ..ros2.node import BridgeNode
    from ..service.share import AttachedBus

    try:
        ns = check_namespace(namespace)
        domain = domain_id()
        check_node_name(node_name)
        control_commands = topic_option("--control-commands-topic", control_commands, ns)
        control_states = topic_option("--control-states-topic", control_states, ns)
        base_ids = _base_ids(diff_drive, wheel_radius, wheel_separation)
        prefix = _frame_prefix(frame_prefix)
        constants = _numbers("--torque-constants", torque_constants) if torque_constants else None
        if base_ids and not ids and not o.ids:
            ids = ",".join(map(str, base_ids))
    except (NameError_, ValueError) as error:
        fail(str(error))
    recorder = None
    if mcap_path is not None:
        from ..recording.mcap_file import McapRecorder

        recorder = McapRecorder(mcap_path)
    try:
        bus = open_traced_bus(o, recorder)
    except BaseException:  # the port failed: the recording still ends properly (file closed)
        if recorder is not None:
            recorder.close()
        raise
    node = None
    holding = None
    try:
        motor_list = motor_ids(o, ids, bus)
        try:
            names = make_joint_names(joint_names, motor_list)
            bridge = Bridge(
                motor_list, names, command_timeout, move_velocity, ramp,
                frame_id=prefix + base_frame, torque_constants=constants,
            )  # fmt: skip
            base = None
            if base_ids:
                base = diffdrive.BaseConfig(
                    base_ids[0], base_ids[1], wheel_radius, wheel_separation, left_inverted, right_inverted,
                    max_linear, max_angular, max_linear_accel, max_angular_accel, command_timeout,
                    prefix + odom_frame, prefix + base_frame,
                )  # fmt: skip
                diffdrive.DiffDrive(bridge, base)  # checks the set-up before DDS is touched
            participant = open_participant(dds, domain)
        except (ValueError, OSError) as error:
            fail(str(error))
        node = BridgeNode(bus, bridge, participant, ns, rate, o.product, broadcast_read, recorder, node_name=node_name)
        if recorder is not None:  # odom, /tf and /diagnostics too, besides joint_states and the frames
            node.recorder = recorder.write
        control_topics.attach(node, control_commands, control_states)
        if base is not None:
            diffdrive.attach(node, base, stamped, odom_tf=not no_odom_tf)
        serve_services(participant, node, node_name, ns)
        if not isinstance(bus, AttachedBus):  # our own port (not attached to a holder): shared with others
            holding = share_bus(node, bus, o, motor_list)  # docs/service.md
        stop = install_stop_signals()
        try:
            node.prepare(stop=stop)  # a failed first reading is retried (a line each time) until Ctrl-C
        except NurimcError as error:
            if stop.is_set():
                fail(f"stopped before any motor answered: {error}", EXIT_DEVICE)
            raise
        joints = ", ".join(f"{n}=ID {i}" for n, i in zip(names, motor_list, strict=True))
        out.print(
            f"ready: domain {domain}, node {topic(ns, node_name)}, {node.joint_states_topic} ({joints}); commands on "
            f"{'' if ns == '/' else ns}/position_commands, velocity_commands, estop; /diagnostics; "
            f"ros2_control: {control_commands} -> {control_states}"
            + (f"; base: {topic(ns, 'cmd_vel')} -> {topic(ns, 'odom')}, /tf" if base is not None else ""),
            soft_wrap=True,
        )
        node.start()
        wait_for_signal(node.done, seconds, stop)
        node.stop()
        if node.failure:
            fail(node.failure, EXIT_DEVICE)
    finally:
        if holding is not None:
            holding.close("the holder (nurimc ros2) ended")
        if node is not None:
            node.close()
        bus.close()
        if recorder is not None:
            recorder.close()


DDS_STACKS = ("rtps", "cyclone")


def serve_services(participant: Any, node: Any, name: str, ns: str) -> None:
    """The bridge's parameters and services (ros2/parameters.py, ros2/services.py), on our RTPS
    participant: Cyclone DDS's Python binding cannot answer a ROS 2 client (docs/ros2.md)."""
    if not hasattr(participant, "service"):
        node._log("note: --dds cyclone serves no ROS 2 parameters or services (use --dds rtps, the default)")
        return
    from ..ros2.services import bridge_services

    for spec in bridge_services(node, name, ns):
        participant.service(spec.name, spec.request, spec.response, spec.handler)


def open_participant(stack: str, domain: int) -> Any:
    """The bridge's DDS participant: ours (ros2/rtps/, the default) or Cyclone DDS's (ros2/dds.py)."""
    if stack not in DDS_STACKS:
        raise ValueError(f"--dds {stack!r}: give one of {', '.join(DDS_STACKS)}")
    if stack == "cyclone":
        from ..ros2.dds import Participant

        return Participant(domain)
    from ..ros2.rtps.topics import RtpsParticipant

    return RtpsParticipant(domain, log=lambda text: print(text, file=sys.stderr, flush=True))


def share_bus(node: Any, bus: Bus, o: Options, motor_list: list[int]) -> Any:
    """Serve the bridge's bus to other nurimc programs; an emergency stop from any of them is
    reported here (the motors stay stopped until a command moves them again)."""
    from ..service.hold import hold_port

    def reported(event: dict[str, Any]) -> None:
        if event.get("type") == "estop" and event.get("from") != "nurimc ros2":  # its own stop is said already
            stopped = ", ".join(map(str, event.get("stopped", []))) or "none"
            missing = ", ".join(map(str, event.get("not_confirmed", [])))
            node._log(
                f"estop on the shared bus: control off read back on ID {stopped}"
                + (f"; NOT confirmed: ID {missing}" if missing else "")
            )

    port = o.port or os.environ.get("NURIMC_PORT", "")
    motors = {i: bus.baudrate for i in motor_list}
    # the bridge is a client of its own bus service (ros2/node.py): that service is the one served,
    # so attached readers share its polls and its estop is everyone's (told by the service itself)
    holding = hold_port(bus, port, motors, "nurimc ros2", node._log, reported, service=node.service)
    return holding


def _frame_prefix(text: str) -> str:
    """--frame-prefix: letters, digits, _ and / (tf2 frame ids), not starting with /."""
    if text and (text.startswith("/") or not all(c.isascii() and (c.isalnum() or c in "_/") for c in text)):
        raise ValueError(f"--frame-prefix {text!r}: use letters, digits, _ and /, not starting with / (e.g. robot1/)")
    return text


def _numbers(option: str, text: str) -> list[float]:
    """A comma-separated list of numbers (checked further by whoever takes them)."""
    try:
        return [float(item) for item in text.split(",")]
    except ValueError:
        raise ValueError(f"{option} {text}: give numbers separated by commas, one per joint (e.g. 0.12,0.12)") from None


def _base_ids(text: str | None, radius: float | None, separation: float | None) -> list[int]:
    """--diff-drive LEFT,RIGHT (with its wheel geometry), or [] without it."""
    if not text:
        if radius is not None or separation is not None:
            raise ValueError("--wheel-radius/--wheel-separation need --diff-drive LEFT_ID,RIGHT_ID")
        return []
    ids = parse_ids(text, "--diff-drive")
    if len(ids) != 2 or ids[0] == ids[1]:
        raise ValueError(f"--diff-drive {text}: give two different IDs, left then right (e.g. 1,2)")
    if radius is None or separation is None:
        raise ValueError("--diff-drive needs --wheel-radius M and --wheel-separation M")
    return ids


def register(app: typer.Typer) -> None:
    app.command(name="ros2")(ros2)
