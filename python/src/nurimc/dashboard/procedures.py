"""The console's multi-step bus actions as procedures (sans-I/O, as the core's): the emergency
stop, set-zero and the step run. They yield actions (Send, Receive, Wait, Now, Note ...) and the
Bus's driver carries them out, so the console's worker has no sleep loop and no clock of its
own; busy windows are the BusCore's. Progress goes out as Note events (a reading for the plots),
and the worker's note handler may throw in an interruption (a newer emergency stop).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..client.actions import Note, Now, Procedure, Receive, Wait
from ..client.core import BusCore
from ..errors import NurimcError, PortLost
from ..motor import MotorProcedures, MotorState
from ..protocol import BROADCAST_ID, Request, ResetPosition, SetControl
from ..settings import setting

ESTOP_RECHECK = 0.05  # s between two rounds of reading control back after an emergency stop
ZERO_WAIT = 0.5  # s the new zero may take to show in the readings
ZERO_RECHECK = 0.02


@dataclass(frozen=True, slots=True)
class Reading:
    """A state read during a procedure (for the plots); `t` on the driver's clock."""

    state: MotorState
    t: float


def _at_rate(core: BusCore, rate: int) -> Procedure[None]:
    if core.baudrate != rate:
        yield from core.set_baud(rate)


def emergency_stop(
    core: BusCore, motors: Mapping[int, tuple[MotorProcedures, int]], verify_seconds: float
) -> Procedure[dict[str, Any]]:
    """Control off, broadcast at every rate a motor was found at (and the current one), then
    each motor told and read back until it reads "off" or `verify_seconds` pass.

    `motors`: ID -> (its procedures, the rate it answers at). A controller busy writing its
    EEPROM (50-300 ms) ignores frames, so a broadcast can be lost on it: each one is told again
    until it confirms. A lost port (PortLost) is never swallowed: the caller latches the stop.
    """
    rates = sorted({*(rate for _, rate in motors.values()), core.baudrate})
    for rate in rates:
        yield from _at_rate(core, rate)
        yield from core.tell(SetControl(BROADCAST_ID, 1))
    for motor, rate in motors.values():
        yield from _at_rate(core, rate)
        yield from _told_again(motor)
    controls: dict[str, Any] = {}
    unconfirmed = set(motors)
    deadline = (yield Now()) + verify_seconds
    while unconfirmed:
        for device_id in sorted(unconfirmed):
            motor, rate = motors[device_id]
            yield from _at_rate(core, rate)
            controls[str(device_id)] = value = yield from _control(motor)
            if value == "off":
                unconfirmed.discard(device_id)
            else:  # still on, or not answering yet: tell it again
                yield from _told_again(motor)
        if not unconfirmed or (yield Now()) >= deadline:
            break
        yield Wait(ESTOP_RECHECK)
    return {"rates": rates, "control": controls}


def _told_again(motor: MotorProcedures) -> Procedure[None]:
    try:
        yield from motor.release()  # the handle remembers: the next move turns control on again
    except PortLost:
        raise
    except NurimcError:  # the broadcast went out; the read-back tells the truth
        pass


def _control(motor: MotorProcedures) -> Procedure[str]:
    try:
        return str((yield from motor.get("control")))
    except PortLost:
        raise
    except NurimcError as error:
        return f"unknown: {error}"


def probe_port() -> Procedure[int]:
    """Look at the port without sending: takes what came unasked (noise, a late answer: dropped)
    and fails if the port is gone. Returns the number of bytes dropped."""
    now = yield Now()
    data: bytes = yield Receive(64, now)
    return len(data)


def set_zero(core: BusCore, motor: MotorProcedures) -> Procedure[MotorState]:
    """Make the present position zero; returns the first reading that shows it (or the last
    one after ZERO_WAIT: the caller reports where it is)."""
    yield from core.tell(ResetPosition(motor.id))
    motor.tracker.reset()
    deadline = (yield Now()) + ZERO_WAIT
    while True:  # the new zero shows in the next reading
        state = yield from motor.read_state()
        if abs(state.device_position) < 1.0 or (yield Now()) >= deadline:
            return state
        yield Wait(ZERO_RECHECK)


def step_run(motor: MotorProcedures, target: float, rpm: float | None, duration: float) -> Procedure[list[Reading]]:
    """Move to `target` and read the position for `duration` seconds; each reading is also a
    Note(Reading) as it comes (plots; the note handler may interrupt the run)."""
    yield from motor.move_to(target, rpm=rpm)
    began = yield Now()
    readings: list[Reading] = []
    while (now := (yield Now())) - began < duration:
        state = yield from motor.read_state()
        reading = Reading(state, now - began)
        readings.append(reading)
        yield Note(reading)
    return readings


def gains_at_start(motor: MotorProcedures) -> Procedure[dict[str, int]]:
    """The position gains the motor has now, read from it (one request): a step run is labelled
    with these, never with what is typed in the page's fields (which may not have been written)."""
    request = motor.line.make(setting("position-kp").request, motor.id)
    assert isinstance(request, Request)
    answer = yield from motor.core.ask(request)
    fields = answer.fields()
    return {"kp": fields["kp"], "ki": fields["ki"], "kd": fields["kd"]}
