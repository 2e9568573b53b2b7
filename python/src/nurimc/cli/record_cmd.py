"""`nurimc record --mcap FILE`: joint states and every frame on the bus, as a ROS 2 MCAP recording."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import typer

from ..budgets import READ_LIMITS_HELP
from ..errors import NurimcError
from .common import EXIT_DEVICE, EXIT_USAGE, Number, fail, options, out, say_line
from .i18n import tr
from .ros2_limits import RATE, SECONDS

CHECKPOINT = Number("--checkpoint", 0.05, 60, "s")
PORT_WAIT = Number("--port-wait", 0, 3600, "s")


#: where a joint whose continuous position became uncertain is said (as the ROS 2 bridge does)
DIAGNOSTICS_TOPIC = "/diagnostics"


def note_uncertain(recorder: Any, bridge: Any, uncertain: set[int], stamp_ns: int, port: str) -> bool:
    """When the joints whose continuous position may be off by whole turns change (nurimc.procedures.multiturn),
    write the bridge's diagnostics (each joint's position_uncertain) to the recording; True if written."""
    unsure = {j.id for j in bridge.joints if j.state is not None and j.state.position_uncertain}
    if unsure == uncertain:
        return False
    uncertain.clear()
    uncertain.update(unsure)
    recorder.write(DIAGNOSTICS_TOPIC, bridge.diagnostics(stamp_ns, "nurimc record", port, {}))
    return True


def record(
    ctx: typer.Context,
    mcap_path: Path = typer.Option(..., "--mcap", help="The MCAP file to write (ros2msg schemas, CDR)."),
    ids: str = typer.Option(None, "--ids", help="Controller IDs to read: 1,2 (default: those found)."),
    namespace: str = typer.Option("/", "--namespace", "-n", help="Namespace of the joint_states topic."),
    joint_names: str = typer.Option(None, "--joint-names", help="One name per ID (default motor_<ID>)."),
    rate: float = typer.Option(
        50.0, "--rate", help=f"Readings per second ({RATE.allowed}); 0 = as fast as the bus allows.", parser=RATE
    ),
    seconds: float = typer.Option(
        None,
        "--seconds",
        help=f"Stop after this many seconds ({SECONDS.allowed}; default: until Ctrl-C).",
        parser=SECONDS,
    ),
    checkpoint: float = typer.Option(
        1.0,
        "--checkpoint",
        help=f"Seconds between points where the file is complete ({CHECKPOINT.allowed}); a crash loses at most that.",
        parser=CHECKPOINT,
    ),
    port_wait: float = typer.Option(
        30.0,
        "--port-wait",
        help=f"Seconds to wait for a lost port to come back before the recording ends ({PORT_WAIT.allowed}).",
        parser=PORT_WAIT,
    ),
    source: Path = typer.Option(
        None,
        "--from",
        help="Convert a traffic log or logic-analyzer capture (.sr, nurimc decoder output) instead of reading a bus.",
    ),
) -> None:
    """Record joint_states (sensor_msgs/JointState) and every raw frame with its direction and time.

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 record --mcap run.mcap --ids 1,2 --seconds 10
    """
    o = options(ctx)
    from ..service.core import BusService
    from ..service.readings import ServiceReadings
    from ..service.share import AttachedBus
    from .attach import SharedReadings
    from .ros2_cmd import motor_ids, need_mcap, open_traced_bus, wait_for_signal

    need_mcap()  # no DDS stack: the messages are written by recording/cdr.py
    if source is not None:  # docs/sigrok.md: a capture from a real robot, into Foxglove
        from ..recording.sigrok import convert_to_mcap

        counts = convert_to_mcap(source, mcap_path)
        out.print(tr(f"wrote {mcap_path}: {counts} frames from {source}"), soft_wrap=True, markup=False)
        return
    from ..recording.mcap_file import FRAMES_TOPIC, McapRecorder
    from ..ros2.bridge import Bridge
    from ..ros2.names import NameError_, topic
    from ..ros2.names import joint_names as make_joint_names
    from ..ros2.names import namespace as check_namespace

    try:
        state_topic = topic(check_namespace(namespace), "joint_states")
    except NameError_ as error:
        fail(str(error))
    try:
        recorder = McapRecorder(mcap_path, checkpoint_seconds=checkpoint)
    except ValueError as error:
        fail(str(error))
    try:
        bus = open_traced_bus(o, recorder)
    except BaseException:  # the port failed: the recording still ends properly (file closed)
        if recorder is not None:
            recorder.close()
        raise
    stop = threading.Event()
    recorder.on_failure = lambda _why: stop.set()  # disk full: the recording ends at once (recorder.failed)
    port_error: list[str] = []
    service: BusService | None = None
    try:
        motor_list = motor_ids(o, ids, bus)
        try:
            bridge = Bridge(motor_list, make_joint_names(joint_names, motor_list))
        except ValueError as error:
            fail(str(error))
        out.print(
            tr(
                f"ready: recording {state_topic} and {FRAMES_TOPIC} to {mcap_path} "
                + (f"(ends after {seconds:g} s, or Ctrl-C)" if seconds else "(Ctrl-C ends)")
            ),
            soft_wrap=True,
            markup=False,
        )

        # the readings come from a bus service's poll schedule: the holder's when attached (no reads of
        # our own), else a service of our own on this bus (docs/service.md); the loop only takes them
        readings: SharedReadings | ServiceReadings
        if isinstance(bus, AttachedBus):
            readings = SharedReadings(bus, motor_list, rate or 50.0)
        else:
            product = o.product if o.product_given else "mc"
            service = BusService(bus, say=say_line, product=product, program="nurimc record").start()
            readings = ServiceReadings(service, motor_list, rate)

        def lost_text() -> str:
            transport = service.outage.transport if service is not None else None
            return transport.lost_text() if transport is not None else "the port is lost"

        def loop() -> None:
            period = 1.0 / rate if rate else 0.0
            lost_since: float | None = None
            uncertain: set[int] = set()  # joints whose continuous position may be off by whole turns
            while not stop.is_set():
                if service is not None and service.outage.down:  # said once by the service; polls pause
                    lost_since = time.monotonic() if lost_since is None else lost_since
                    if time.monotonic() - lost_since >= port_wait:  # gone for good: end, then say so
                        port_error.append(f"{lost_text()} (waited {port_wait:g} s, --port-wait)")
                        stop.set()
                        return
                    service.outage.wait_up(min(0.5, port_wait))
                    if stop.is_set() and service.outage.down:  # ended (Ctrl-C, --seconds) while the port is lost
                        port_error.append(lost_text())
                    continue
                lost_since = None
                try:
                    bridge.readings(readings.take(max(2 * period, 0.1)))
                except NurimcError as error:  # the holder ended: end the recording, then say so
                    port_error.append(str(error))
                    stop.set()
                    return
                now_ns = time.time_ns()
                message = bridge.joint_state(now_ns)
                if message is not None:
                    recorder.joint_state(state_topic, message)
                note_uncertain(recorder, bridge, uncertain, now_ns, o.port or "")

        worker = threading.Thread(target=loop, name="nurimc-record", daemon=True)
        worker.start()
        wait_for_signal(stop, seconds)
        stop.set()
        worker.join(timeout=5)
    finally:
        if service is not None:
            service.close()
        bus.close()
        recorder.close()
    if recorder.failed:  # the disk (full, gone): one line, exit 1
        fail(f"the recording stopped: {recorder.failed}", EXIT_DEVICE)
    counts = ", ".join(tr(f"{n} on {t}") for t, n in sorted(recorder.counts.items()))
    out.print(tr(f"wrote {mcap_path}: {counts or tr('no messages')}"), soft_wrap=True, markup=False)
    if port_error:
        fail(f"the recording stopped early: {port_error[0]} (the file is complete up to then)", EXIT_DEVICE)


def repair_mcap(
    torn: Path = typer.Argument(..., help="The MCAP file to repair (it is only read)."),
    output: Path = typer.Option(
        None, "--out", "-o", help="Where to write the repaired file (default TORN.repaired.mcap)."
    ),
    read_limits: str = typer.Option(None, "--read-limits", help=READ_LIMITS_HELP),
) -> None:
    """Repair a torn MCAP file (a crash mid-write, a copy cut short): keep every whole record, write a complete file.

    Example: nurimc repair-mcap run.mcap --out run-fixed.mcap
    """
    from .ros2_cmd import need_mcap

    need_mcap()
    from ..budgets import default_budget
    from ..recording.repair import repair

    target = output if output is not None else torn.with_suffix(".repaired.mcap")
    try:
        result = repair(torn, target, default_budget().with_text(read_limits or ""))
    except ValueError as error:
        fail(str(error))
    if result.complete:
        complete = f"{torn} was complete; copied {result.messages} messages to {target}"
        out.print(tr(complete), soft_wrap=True, markup=False)
    elif result.lost and not result.messages:  # nothing whole in it (a chunk bomb, all chunks broken)
        fail(f"nothing kept from {torn}: {result.problem}", EXIT_USAGE)
    elif result.lost:  # broken chunks skipped, the rest kept (recording/salvage.py)
        out.print(
            tr(f"wrote {target}: {result.messages} messages kept; skipped in {torn}: {result.problem}"),
            soft_wrap=True,
            markup=False,
        )
    else:
        out.print(
            tr(f"wrote {target}: {result.messages} messages kept; {torn} stopped at {result.problem}"),
            soft_wrap=True,
            markup=False,
        )


def register(app: typer.Typer) -> None:
    app.command(name="record")(record)
    app.command(name="repair-mcap")(repair_mcap)
