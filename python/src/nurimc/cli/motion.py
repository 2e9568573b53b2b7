"""move, run, stop, release, hold: motion. Each needs an explicit --id."""

from __future__ import annotations

from typing import Any

import typer

from ..errors import InputError, NotArrived, NurimcError
from ..inputs import number
from ..procedures.motor import RUN_RAMP
from ..protocol.host import LIMITS
from .common import (
    EXIT_DEVICE,
    InputBadParameter,
    Number,
    Options,
    SignedValuesCommand,
    emit,
    fail,
    motor_for,
    one_id,
    open_bus,
    options,
)

POSITION = LIMITS["position_deg"]
RPM_MIN, RPM_MAX = LIMITS["speed_rpm_min"], LIMITS["speed_rpm_max"]
SECONDS_MIN, SECONDS_MAX = LIMITS["arrival_s_min"], LIMITS["arrival_s_max"]

DEGREES = Number("degrees", -POSITION, POSITION, "°", step=0.01)
RPM = Number("--rpm", RPM_MIN, RPM_MAX, "RPM", step=0.1)
SECONDS = Number("--seconds", SECONDS_MIN, SECONDS_MAX, "s", step=0.1)
SIGNED_RPM = Number("rpm", -RPM_MAX, RPM_MAX, "RPM", step=0.1)
RAMP = Number("--ramp", SECONDS_MIN, SECONDS_MAX, "s", step=0.1)
TIMEOUT = Number("--timeout", 0.1, 3600, "s")

# `move -90` and `run -60`: a negative number is a value, not an option (see register()).
NUMBERS_FIRST: dict[str, Any] = {"ignore_unknown_options": True}


def _signed_rpm(value: Any) -> float:
    """run's speed: exactly 0 stops; anything else must be a speed the wire can carry (0.04 RPM,
    which the wire would round to 0, is refused rather than taken as a stop)."""
    if isinstance(value, str) and value.strip() in ("0", "-0", "+0", "0.0", "-0.0", "+0.0"):
        return 0.0
    try:
        exact = number(value, "rpm", -RPM_MAX, RPM_MAX, "RPM")  # checked before rounding: no note first
    except InputError as error:
        raise InputBadParameter(str(error)) from None
    if round(abs(exact), 1) < RPM_MIN:
        raise InputBadParameter(
            f"rpm: {value} RPM is too slow for the wire; give {RPM_MIN}..{RPM_MAX} RPM either way, or 0 to stop"
        )
    rpm: float = SIGNED_RPM(value)
    return rpm


def move(
    ctx: typer.Context,
    degrees: float = typer.Argument(
        ...,
        help=f"Target (CCW +), or the amount with --by: {DEGREES.allowed}.",
        parser=DEGREES,
    ),
    by: bool = typer.Option(False, "--by", help="Move by DEGREES from where the motor is."),
    rpm: float = typer.Option(None, help=f"Speed: {RPM.allowed} (default 30).", parser=RPM),
    seconds: float = typer.Option(
        None,
        help=f"Arrival time instead of --rpm: {SECONDS.allowed}.",
        parser=SECONDS,
    ),
    wait: bool = typer.Option(False, "--wait", help="Return once the motor is at rest at the target."),
    timeout: float = typer.Option(30.0, help=f"With --wait: give up after {TIMEOUT.allowed}.", parser=TIMEOUT),
) -> None:
    """Move to a position (or by an amount) at a speed or in a time.

    Example: nurimc --port /dev/ttyUSB0 --id 1 move 90 --rpm 60
    """
    o = options(ctx)
    if rpm is not None and seconds is not None:
        fail("move: give --rpm (a speed) or --seconds (an arrival time), not both")
    if rpm is None and seconds is None:
        rpm = 30.0  # a gentle default
    with open_bus(o) as bus:
        motor = motor_for(bus, o, one_id(o))
        try:
            (motor.move_by if by else motor.move_to)(degrees, rpm=rpm, seconds=seconds, wait=wait, timeout=timeout)
        except NotArrived as error:
            coarse = _factory_resolution_hint(motor)
            if coarse:
                fail(f"{error}; {coarse}", EXIT_DEVICE)
            raise
        state = motor.read_state() if wait else None
    what = f"by {degrees}°" if by else f"to {degrees}°"
    how = f"at {rpm} RPM" if rpm is not None else f"in {seconds} s"
    data: dict[str, Any] = {
        "id": motor.id,
        "move": "by" if by else "to",
        "degrees": degrees,
        "rpm": rpm,
        "seconds": seconds,
    }
    if state is not None:
        data["arrived_deg"] = state.device_position
    text = f"ID {motor.id}: moving {what} {how}"
    if state is not None:
        text = f"ID {motor.id}: arrived at {state.device_position:g}° (moved {what} {how})"
    emit(o, data, text)


#: the document's factory resolution (MC: 4 encoder pulses, 16 counts a turn: 22.5° steps)
FACTORY_RESOLUTION, FACTORY_STEP_DEG = 4, 22.5


def _factory_resolution_hint(motor: Any) -> str:
    """Why a move did not arrive, when it is the factory resolution: positions come in 22.5°
    steps (a simulator started with sim:// or --resolution 4, or a controller never set up)."""
    try:
        resolution = motor.get("resolution")
    except (NurimcError, KeyError, ValueError):
        return ""
    if resolution != FACTORY_RESOLUTION:
        return ""
    return (
        f"its resolution is the factory {FACTORY_RESOLUTION}, so it reads positions in {FACTORY_STEP_DEG:g}° steps: "
        f"set the encoder's pulses (nurimc --id {motor.id} set resolution 1024, as nurimc sim has) "
        f"or move to a multiple of {FACTORY_STEP_DEG:g}°"
    )


def run(
    ctx: typer.Context,
    rpm: float = typer.Argument(
        ...,
        help=f"Speed, CCW positive: {SIGNED_RPM.allowed}; 0 stops (as `stop`).",
        parser=_signed_rpm,
    ),
    ramp: float = typer.Option(RUN_RAMP, help=f"Time to reach the speed: {RAMP.allowed}.", parser=RAMP),
) -> None:
    """Turn at a speed, ramping up.

    Example: nurimc --port /dev/ttyUSB0 --id 1 run -120 --ramp 1
    """
    o = options(ctx)
    if rpm == 0:
        _stop(o, ramp)
        return
    with open_bus(o) as bus:
        motor_for(bus, o, one_id(o)).run(rpm, ramp)
    emit(o, {"id": o.ids[0], "rpm": rpm, "ramp_s": ramp}, f"ID {o.ids[0]}: running at {rpm} RPM")


def stop(
    ctx: typer.Context,
    ramp: float = typer.Option(0.5, help=f"Time to slow down: {RAMP.allowed}.", parser=RAMP),
) -> None:
    """Slow to a stop and hold there (speed 0, read back, then hold; see docs/cli.md).

    Example: nurimc --port /dev/ttyUSB0 --id 1 stop
    """
    _stop(options(ctx), ramp)


def _stop(o: Options, ramp: float) -> None:
    with open_bus(o) as bus:
        state = bus.motor(one_id(o), o.product).stop(ramp)
    emit(
        o,
        {"id": o.ids[0], "stopped": True, "position_deg": state.device_position, "control": "on"},
        f"ID {o.ids[0]}: stopped at {state.device_position:g}°, holding",
    )


def release(ctx: typer.Context) -> None:
    """Control off: the motor is no longer driven and coasts to a stop.

    Example: nurimc --port /dev/ttyUSB0 --id 1 release
    """
    o = options(ctx)
    with open_bus(o) as bus:
        motor_for(bus, o, one_id(o)).release()
    emit(o, {"id": o.ids[0], "control": "off"}, f"ID {o.ids[0]}: released (control off)")


def hold(ctx: typer.Context) -> None:
    """Control on, holding the present position.

    Example: nurimc --port /dev/ttyUSB0 --id 1 hold
    """
    o = options(ctx)
    with open_bus(o) as bus:
        motor_for(bus, o, one_id(o)).hold()
    emit(o, {"id": o.ids[0], "control": "on"}, f"ID {o.ids[0]}: holding")


def register(app: typer.Typer) -> None:
    app.command(cls=SignedValuesCommand, context_settings=NUMBERS_FIRST)(move)
    app.command(cls=SignedValuesCommand, context_settings=NUMBERS_FIRST)(run)
    app.command()(release)
    app.command()(stop)
    app.command()(hold)
