"""`nurimc set-zero`: the present position becomes zero (the document's position reset, §15), read
back, as the console's Set zero button does."""

from __future__ import annotations

import typer

from ..core.actions import Now, Procedure, Wait
from ..core.buscore import BusCore
from ..procedures.config import _in_line
from ..procedures.motor import MotorProcedures, MotorState
from ..protocol import ResetPosition
from .common import EXIT_DEVICE, emit, fail, motor_for, one_id, open_bus, options

ZERO_WAIT = 0.5  # s the new zero may take to show in the readings
ZERO_RECHECK = 0.02


def zero_here(core: BusCore, motor: MotorProcedures) -> Procedure[MotorState]:
    """Send the position reset in the motor's line; return the first reading that shows zero, or
    the last one after ZERO_WAIT (the caller says where it is)."""
    yield from core.tell(_in_line(core, ResetPosition(motor.id)))
    motor.tracker.reset()
    deadline = (yield Now()) + ZERO_WAIT
    while True:
        state = yield from motor.read_state()
        if abs(state.device_position) < 1.0 or (yield Now()) >= deadline:
            return state
        yield Wait(ZERO_RECHECK)


def set_zero(ctx: typer.Context) -> None:
    """Make the present position zero (position reset) and verify it by reading the position back.

    Example: nurimc --port /dev/ttyUSB0 --id 1 set-zero
    """
    o = options(ctx)
    device_id = one_id(o)
    with open_bus(o) as bus:
        motor = motor_for(bus, o, device_id)
        state = bus.run(zero_here(bus.core, motor.procedures))
    if abs(state.device_position) >= 1.0:
        fail(f"ID {device_id} reads {state.device_position:.2f}° after the position reset, not 0°", EXIT_DEVICE)
    emit(
        o,
        {"id": device_id, "zeroed": True, "position_deg": state.device_position},
        f"ID {device_id}: the present position is now 0° (verified)",
    )


def register(app: typer.Typer) -> None:
    app.command(name="set-zero")(set_zero)
