"""scan, ping, status, watch: finding controllers and reading them."""

from __future__ import annotations

import time
from typing import Any

import typer
from rich.live import Live
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from ..client.sync import Bus
from ..discovery import Progress as ScanProgress
from ..discovery import discover
from ..errors import NurimcError
from ..inputs import UNIT_SHOWN, with_unit
from ..motor import MotorState
from ..products import DESCRIPTIONS
from ..protocol import BAUD_RATES
from ..settings import SETTINGS
from .common import STOP, Number, check_baud, emit, err, fail, motor_for, one_id, open_bus, options, parse_ids, table

INTERVAL = Number("--interval", 0.01, 3600, "s")
COUNT = Number("--count", 0, 1_000_000, whole=True)


def _rates(text: str | None) -> list[int]:
    if not text:
        return list(BAUD_RATES)
    return list(dict.fromkeys(check_baud(r, "--rates") for r in text.split(",")))


def scan(
    ctx: typer.Context,
    rates: str = typer.Option(None, help="Only these rates, e.g. 9600,115200 (default: all 18)."),
    ids: str = typer.Option(None, "--ids", help="Only ping these IDs one by one, e.g. 0-10 (default: all)."),
) -> None:
    """Find every controller across rates and IDs.

    Example: nurimc --port /dev/ttyUSB0 scan --rates 9600,115200
    """
    o = options(ctx)
    rate_list, id_list = _rates(rates), parse_ids(ids, "--ids") or None
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} rates"),
        TimeElapsedColumn(),
    )
    with open_bus(o) as bus, Progress(*columns, console=err, disable=o.json, transient=True) as bar:
        task = bar.add_task("scanning", total=len(rate_list))

        def show(event: Any) -> None:
            if isinstance(event, ScanProgress):
                where = f"{event.rate} bps" + (f", ID {event.walking_id}" if event.walking_id is not None else "")
                bar.update(task, completed=event.rate_index, description=f"{where}: {len(event.found)} found")

        found = bus.run(discover(bus.core, rate_list, id_list), on_note=show)
        guesses = {}
        for f in found:
            bus.baudrate = f.baudrate
            guess = "?"
            if not f.collision and f.line == "mc":  # only MC has a resolution to tell BLMC-H by
                guess = product_guess(bus, f.id)
            elif not f.collision:
                guess = f.line
            guesses[(f.id, f.baudrate)] = guess
    rows = table(f"{len(found)} controller(s) found", "ID", "baud", "firmware", "line", "product (guess)", "note")
    for f in found:
        note = "several controllers share this ID" if f.collision else DESCRIPTIONS.get(f.line, "")
        rows.add_row(str(f.id), str(f.baudrate), str(f.firmware), f.line, guesses[(f.id, f.baudrate)], note)
    emit(
        o,
        [
            {
                "id": f.id,
                "baud": f.baudrate,
                "firmware": f.firmware,
                "collision": f.collision,
                "line": f.line,
                "product_guess": guesses[(f.id, f.baudrate)],
            }
            for f in found
        ],
        rows,
    )


def product_guess(bus: Bus, device_id: int) -> str:
    """The protocol does not say which product answers. A guess from the resolution setting:
    hall pole counts (BLMC-H) are small even numbers, encoder pulse counts (MC) usually are not."""
    try:
        resolution = bus.motor(device_id).get("resolution")
    except NurimcError:
        return "?"
    if resolution == 4:
        return "unknown (default resolution 4)"
    return "BLMC-H?" if isinstance(resolution, int) and resolution <= 24 and resolution % 2 == 0 else "MC?"


def ping(ctx: typer.Context) -> None:
    """Check that a controller answers, and how fast.

    Example: nurimc --port sim://?ids=0,1 --id 1 ping
    """
    o = options(ctx)
    device_id = one_id(o)
    with open_bus(o) as bus:
        start = time.perf_counter()
        bus.motor(device_id).ping()
        elapsed = time.perf_counter() - start
    emit(
        o,
        {"id": device_id, "baud": o.baud, "ok": True, "round_trip_ms": round(elapsed * 1000, 3)},
        f"ID {device_id} answers at {o.baud} bps ({elapsed * 1000:.1f} ms)",
    )


def _state_dict(state: MotorState) -> dict[str, Any]:
    return {
        "position_deg": state.position,
        "device_position_deg": state.device_position,
        "speed_rpm": state.speed,
        "current_a": state.current,
        "direction": state.direction,
    }


def _state_rows(state: MotorState, speed_only: bool = False) -> list[tuple[str, str]]:
    """The reading, each row with its unit; names that cannot be taken for a setting's.
    A speed-only line (SM) reads its speed feedback: the speed is signed, the position in 0.1°."""
    return [
        ("position", with_unit(state.position, "°") + (" (0.1° steps, from speed feedback)" if speed_only else "")),
        ("device position", with_unit(state.device_position, "°")),
        ("speed", with_unit(state.speed, "RPM") + (" (signed, CCW +)" if speed_only else "")),
        ("current", with_unit(state.current, "A")),
        ("position sign", f"{state.direction} (the side of zero the device reports)"),
    ]


def _setting_text(name: str, value: object) -> str:
    s = SETTINGS.get(name)
    unit = UNIT_SHOWN.get(s.spec.unit, "") if s is not None else ""
    return with_unit(value, unit) if isinstance(value, int | float) else str(value)


def status(ctx: typer.Context) -> None:
    """Position, speed, current, direction and every setting of one controller.

    Example: nurimc --port /dev/ttyUSB0 --id 1 status --json
    """
    o = options(ctx)
    device_id = one_id(o)
    with open_bus(o) as bus:
        motor = motor_for(bus, o, device_id, acts=False)
        state = motor.read_state()
        settings = motor.read_settings()
    line = motor.procedures.line
    product = motor.procedures.profile.key
    rows = table(f"ID {device_id} at {o.baud} bps: {line.title} ({product})", "reading", "value")
    for key, text in _state_rows(state, speed_only=not line.has("request_position")):
        rows.add_row(key, text)
    rows.add_section()
    rows.add_row("[bold]setting[/]", "")
    for key, value in settings.items():
        rows.add_row(f"{key}", _setting_text(key, value))
    emit(
        o,
        {
            "id": device_id,
            "baud": o.baud,
            "line": line.key,
            "product": product,
            "state": _state_dict(state),
            "settings": settings,
        },
        rows,
    )


def watch(
    ctx: typer.Context,
    interval: float = typer.Option(0.1, help=f"Seconds between readings ({INTERVAL.allowed}).", parser=INTERVAL),
    count: int = typer.Option(
        0, help=f"Stop after this many readings ({COUNT.allowed}; 0: until Ctrl+C).", parser=COUNT
    ),
) -> None:
    """Live table of one or many motors (Ctrl+C to stop).

    Example: nurimc --port /dev/ttyUSB0 --id 1,2,3 watch
    """
    o = options(ctx)
    if not o.ids:
        fail("watch: give the motors to watch with --id 1,2,3")
    readings: list[dict[str, Any]] = []
    with open_bus(o) as bus:
        motors = [motor_for(bus, o, i, acts=False) for i in o.ids]

        def render() -> Any:
            rows = table(None, "ID", "position °", "speed RPM", "current A", "position sign")
            for m in motors:
                try:
                    s = m.read_state()
                    readings.append({"id": m.id, **_state_dict(s)})
                    rows.add_row(str(m.id), f"{s.position:.2f}", f"{s.speed:.1f}", f"{s.current:.1f}", s.direction)
                except NurimcError as error:
                    rows.add_row(str(m.id), "[red]no answer[/]", "", "", escape(str(error)[:40]))
            return rows

        n = 0
        try:
            with Live(render(), console=err if o.json else None, auto_refresh=False, transient=o.json) as live:
                while True:
                    n += 1
                    if count and n >= count:
                        break
                    time.sleep(interval)
                    live.update(render(), refresh=True)
        except STOP:
            pass  # Ctrl+C or SIGTERM: the normal end of watching
    emit(o, readings)


def register(app: typer.Typer) -> None:
    for command in (scan, ping, status, watch):
        app.command()(command)
