"""The console's multi-step bus actions as procedures (sans-I/O, as the core's): the emergency
stop (the one of nurimc.procedures.stop), set-zero and the step run. They yield actions (Send,
Receive, Wait, Now, Note ...) and the Bus's driver carries them out, so the console's worker
has no sleep loop and no clock of its own; busy windows are the BusCore's. Progress goes out as
Note events (a reading for the plots), and the worker's note handler may throw in an
interruption (a newer emergency stop).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..core.actions import Note, Now, Procedure, Receive, Wait
from ..core.buscore import BusCore
from ..procedures.motor import MotorProcedures, MotorState
from ..procedures.settings import setting
from ..procedures.stop import emergency_stop as the_stop
from ..protocol import Request, ResetPosition
from ..protocol.host import STOP_VERIFY

ZERO_WAIT = 0.5  # s the new zero may take to show in the readings
ZERO_RECHECK = 0.02


@dataclass(frozen=True, slots=True)
class Reading:
    """A state read during a procedure (for the plots); `t` on the driver's clock."""

    state: MotorState
    t: float


def emergency_stop(
    core: BusCore, motors: Mapping[int, tuple[MotorProcedures, int]], verify_seconds: float = STOP_VERIFY
) -> Procedure[dict[str, Any]]:
    """The one emergency stop (nurimc.procedures.stop, docs/service.md), its result as the pages
    show it: rates, each motor's control read back, and which motors it could not read back."""
    result = yield from the_stop(core, motors, verify_seconds)
    return {
        "rates": list(result.rates),
        "control": result.control,
        "stopped": list(result.stopped),
        "not_confirmed": list(result.not_confirmed),
        "ok": result.ok,
    }


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
