"""move, run, release (stop), hold: motion. Each needs an explicit --id."""

from __future__ import annotations

import typer

from .app import app
from .common import emit, one_id, open_bus, options


@app.command()
def move(
    ctx: typer.Context,
    degrees: float = typer.Argument(..., help="Target in degrees (CCW +), or the amount with --by."),
    by: bool = typer.Option(False, "--by", help="Move by DEGREES from where the motor is."),
    rpm: float = typer.Option(None, help="Speed in RPM."),
    seconds: float = typer.Option(None, help="Arrival time in seconds (instead of --rpm)."),
) -> None:
    """Move to a position (or by an amount) at a speed or in a time.

    Example: nurimc --port /dev/ttyUSB0 --id 1 move 90 --rpm 60
    """
    o = options(ctx)
    if rpm is None and seconds is None:
        rpm = 30.0  # a gentle default
    with open_bus(o) as bus:
        motor = bus.motor(one_id(o), o.product)
        (motor.move_by if by else motor.move_to)(degrees, rpm=rpm, seconds=seconds)
    what = f"by {degrees}°" if by else f"to {degrees}°"
    how = f"at {rpm} RPM" if rpm is not None else f"in {seconds} s"
    emit(
        o,
        {"id": motor.id, "move": "by" if by else "to", "degrees": degrees, "rpm": rpm, "seconds": seconds},
        f"ID {motor.id}: moving {what} {how}",
    )


@app.command()
def run(
    ctx: typer.Context,
    rpm: float = typer.Argument(..., help="Speed in RPM, CCW positive; not 0 (use release)."),
    ramp: float = typer.Option(0.5, help="Seconds to reach the speed."),
) -> None:
    """Turn at a speed, ramping up.

    Example: nurimc --port /dev/ttyUSB0 --id 1 run -- -120 --ramp 1
    """
    o = options(ctx)
    with open_bus(o) as bus:
        bus.motor(one_id(o), o.product).run(rpm, ramp)
    emit(o, {"id": o.ids[0], "rpm": rpm, "ramp_s": ramp}, f"ID {o.ids[0]}: running at {rpm} RPM")


@app.command()
def release(ctx: typer.Context) -> None:
    """Control off: the motor is no longer driven and coasts to a stop.

    Example: nurimc --port /dev/ttyUSB0 --id 1 release
    """
    o = options(ctx)
    with open_bus(o) as bus:
        bus.motor(one_id(o), o.product).release()
    emit(o, {"id": o.ids[0], "control": "off"}, f"ID {o.ids[0]}: released (control off)")


app.command(name="stop", help="Same as release: control off, the motor coasts to a stop.")(release)


@app.command()
def hold(ctx: typer.Context) -> None:
    """Control on, holding the present position.

    Example: nurimc --port /dev/ttyUSB0 --id 1 hold
    """
    o = options(ctx)
    with open_bus(o) as bus:
        bus.motor(one_id(o), o.product).hold()
    emit(o, {"id": o.ids[0], "control": "on"}, f"ID {o.ids[0]}: holding")
