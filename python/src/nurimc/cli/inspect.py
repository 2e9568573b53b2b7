"""scan, ping, status, watch: finding controllers and reading them."""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import time
from typing import Any

import typer
from rich.live import Live
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.text import Text

from ..drivers.sync import Bus
from ..errors import NurimcError
from ..inputs import UNIT_SHOWN, with_unit
from ..procedures.discovery import FixedLink, RateSkipped, discover
from ..procedures.discovery import Progress as ScanProgress
from ..procedures.journal import RestoreJournal, incomplete_message
from ..procedures.motor import MotorState
from ..procedures.products import DESCRIPTIONS
from ..procedures.settings import SETTINGS
from ..protocol import BAUD_RATES
from ..transport.outage import OutageGuard
from .common import (
    EXIT_INTERRUPTED,
    Number,
    check_baud,
    emit,
    err,
    fail,
    motor_for,
    one_id,
    one_line,
    open_bus,
    options,
    out,
    parse_ids,
    say_line,
    stop_flag,
    table,
)
from .common import note as tell_note
from .i18n import setting_label, tr
from .scan_advice import scan_advice

INTERVAL = Number("--interval", 0.01, 3600, "s")
COUNT = Number("--count", 0, 1_000_000, whole=True)
EXPECT = Number("--expect", 0, 255 * 18, whole=True)


def _rates(text: str | None) -> list[int]:
    if not text:
        return list(BAUD_RATES)
    return list(dict.fromkeys(check_baud(r, "--rates") for r in text.split(",")))


def scan(
    ctx: typer.Context,
    rates: str = typer.Option(None, help="Only these rates, e.g. 9600,115200 (default: all 18)."),
    ids: str = typer.Option(None, "--ids", help="Only ping these IDs one by one, e.g. 0-10 (default: all)."),
    expect: int = typer.Option(
        0,
        "--expect",
        help="Exit 1 unless at least this many controllers are found (0: exit 0 whatever is found).",
        parser=EXPECT,
    ),
) -> None:
    """Find every controller across rates and IDs.

    Example: nurimc --port /dev/ttyUSB0 scan --rates 9600,115200
    """
    o = options(ctx)
    rate_list, id_list = _rates(rates), parse_ids(ids, "--ids") or None
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total} " + tr("rates")),
        TimeElapsedColumn(),
    )
    with (
        open_bus(o) as bus,
        Progress(*columns, console=err, disable=o.json or not err.is_terminal, transient=True) as bar,
    ):
        task = bar.add_task(tr("scanning"), total=len(rate_list))
        so_far: list[Any] = []

        def show(event: Any) -> None:
            if isinstance(event, ScanProgress):
                so_far[:] = event.found
                where = f"{event.rate} bps" + (f", ID {event.walking_id}" if event.walking_id is not None else "")
                bar.update(task, completed=event.rate_index, description=tr(f"{where}: {len(event.found)} found"))
            elif isinstance(event, FixedLink):  # a TCP gateway: one rate, one search, said once
                url = bus.transport.url
                tell_note(
                    f"{url} is a TCP gateway at one rate ({event.rate} bps, set on the gateway): "
                    f"searching once, at {event.rate} bps"
                )
                bar.update(task, total=1)
            elif isinstance(event, RateSkipped):  # the adapter cannot do this rate: say so once, go on
                tell_note(f"{event.reason}; {event.rate} bps skipped")

        try:
            found = bus.run(discover(bus.core, rate_list, id_list), on_note=show)
        except KeyboardInterrupt:
            bar.stop()
            _scan_report(o, list(so_far), {}, interrupted=True)
            raise typer.Exit(EXIT_INTERRUPTED) from None
        guesses = {}
        for f in found:
            bus.baudrate = f.baudrate
            guess = "?"
            if not f.collision and f.line == "mc":  # only MC has a resolution to tell BLMC-H by
                guess = product_guess(bus, f.id)
            elif not f.collision:
                guess = f.line
            guesses[(f.id, f.baudrate)] = guess
    _scan_report(o, found, guesses)
    scan_advice(found, expect)


def _scan_report(o: Any, found: list[Any], guesses: dict[tuple[int, int], str], interrupted: bool = False) -> None:
    """The scan's table or JSON; after Ctrl+C, what was found until then (no product read)."""
    if interrupted:
        err.print(tr(f"interrupted: the scan stopped early; {len(found)} controller(s) found so far"))
    shared = sum(1 for f in found if f.collision)
    title = f"{len(found)} controller(s) found" + (" (interrupted)" if interrupted else "")
    if shared and not interrupted:  # an ID answered by several is not one controller
        title = f"{len(found) - shared} controller(s) found, and {shared} ID(s) shared by two or more controllers"
    rows = table(title, "ID", "baud", "firmware", "line", "product (guess)", "note")
    for f in found:
        note = "several controllers share this ID" if f.collision else DESCRIPTIONS.get(f.line, "")
        firmware = "?" if f.firmware is None else str(f.firmware)  # not read yet when interrupted
        rows.add_row(str(f.id), str(f.baudrate), firmware, f.line, guesses.get((f.id, f.baudrate), "?"), note)
    emit(
        o,
        [
            {
                "id": f.id,
                "baud": f.baudrate,
                "firmware": f.firmware,
                "collision": f.collision,
                "line": f.line,
                "product_guess": guesses.get((f.id, f.baudrate), "?"),
            }
            for f in found
        ],
        rows,
    )


def product_guess(bus: Bus, device_id: int) -> str:
    """The protocol does not say which product answers. A guess from the resolution setting, in the
    words of --product and backups (mc, blmc-h): hall pole counts (BLMC-H) are small even numbers,
    encoder pulse counts (MC) usually are not. The factory 4 tells nothing: mc, the default
    profile, as `backup` writes without --product."""
    try:
        resolution = bus.motor(device_id).get("resolution")
    except NurimcError:
        return "?"
    small_even = isinstance(resolution, int) and resolution != 4 and resolution <= 24 and resolution % 2 == 0
    return "blmc-h" if small_even else "mc"


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
        if not state.speed_signed:  # one reading has no trend: speed feedback's direction byte signs it
            state = dataclasses.replace(state, speed=motor.read_speed(), speed_signed=True)
        settings = motor.read_settings()
    unfinished = RestoreJournal(o.port or os.environ.get("NURIMC_PORT", "")).pending(device_id)
    if unfinished is not None:  # the settings below are part old, part restored (docs/cli.md)
        err.print(f"{tr('warning:')} {tr(incomplete_message(unfinished))}", soft_wrap=True, markup=False)
    line = motor.procedures.line
    product = motor.procedures.profile.key
    rows = table(f"ID {device_id} at {o.baud} bps: {line.title} ({product})", "reading", "value")
    for key, text in _state_rows(state, speed_only=not line.has("request_position")):
        rows.add_row(key, text)
    rows.add_section()
    rows.add_row("[bold]setting[/]", "")
    for key, value in settings.items():  # the name as typed (`get firmware`), in Korean with the document's words
        rows.add_row(Text(setting_label(key)), Text(_setting_text(key, value)))
    document = {
        "id": device_id,
        "baud": o.baud,
        "line": line.key,
        "product": product,
        "state": _state_dict(state),
        "settings": settings,
    }
    emit(o, {**document, "incomplete_restore": unfinished} if unfinished else document, rows)


WATCH_COLUMNS = ("ID", "position °", "speed RPM", "current A", "position sign")


def watch(
    ctx: typer.Context,
    interval: float = typer.Option(0.1, help=f"Seconds between readings ({INTERVAL.allowed}).", parser=INTERVAL),
    count: int = typer.Option(
        0, help=f"Stop after this many readings ({COUNT.allowed}; 0: until Ctrl+C).", parser=COUNT
    ),
) -> None:
    """Live table of one or many motors (Ctrl+C to stop).

    On a terminal the table is redrawn; to a file or a pipe, each reading is a line per motor.

    Example: nurimc --port /dev/ttyUSB0 --id 1,2,3 watch
    """
    o = options(ctx)
    if not o.ids:
        fail("watch: give the motors to watch with --id 1,2,3")
    from ..service.share import AttachedBus, HolderGone  # the shared bus (docs/service.md): only when watching
    from .attach import SharedReadings

    readings: list[dict[str, Any]] = []
    with open_bus(o, reconnect=True) as bus:
        motors = [motor_for(bus, o, i, acts=False) for i in o.ids]
        outage = OutageGuard(bus.transport, say_line)  # lost and back: one line each; every reading is fresh anyway

        shared = SharedReadings(bus, o.ids, 1.0 / interval) if isinstance(bus, AttachedBus) else None

        def read_all() -> list[tuple[str, ...]]:
            rows: list[tuple[str, ...]] = []
            latest = shared.latest() if shared is not None else {}  # attached: the holder's shared readings
            for m in motors:
                try:
                    got = latest.get(m.id, NurimcError("no reading yet")) if shared is not None else None
                    if isinstance(got, NurimcError):
                        raise got
                    s = got if got is not None else m.read_state()
                    readings.append({"id": m.id, **_state_dict(s)})
                    rows.append((str(m.id), f"{s.position:.2f}", f"{s.speed:.1f}", f"{s.current:.1f}", s.direction))
                except HolderGone:  # attached, and the holder ended: said once, and watching ends (exit 1)
                    raise
                except NurimcError as error:
                    rows.append((str(m.id), "no answer", "", "", one_line(error)))  # the whole error: its cause
            return rows

        def render() -> Any:
            rows = table(None, *WATCH_COLUMNS)
            for row in read_all():
                rows.add_row(*(escape(cell) for cell in row))
            return rows

        started = time.monotonic()

        def stream() -> None:
            t = f"{time.monotonic() - started:.3f}"  # the time column: seconds since watch started
            for row in read_all():
                sys.stdout.write("\t".join([*(tr(cell) for cell in row), t]) + "\n")  # as a table's cells
            sys.stdout.flush()

        # Ctrl+C or SIGTERM: the normal end of watching, taken between readings (stop_flag), from
        # the first reading on (a reading that waits out a silent motor is when Ctrl+C comes)
        with stop_flag() as stopped:
            live: Live | None = None
            if o.json or out.is_terminal:
                live = Live(render(), console=err if o.json else out, auto_refresh=False, transient=o.json)
            else:  # a file or a pipe: lines (tab-separated, a header first), not redraws of one table
                sys.stdout.write("\t".join([*(tr(c) for c in WATCH_COLUMNS), tr("t (s)")]) + "\n")
                stream()
            n = 1
            with live or contextlib.nullcontext():
                while not (count and n >= count) and not stopped.wait(interval):
                    n += 1
                    if live is not None:
                        live.update(render(), refresh=True)
                    else:
                        stream()
        outage.close()
    emit(o, readings)


def register(app: typer.Typer) -> None:
    for command in (scan, ping, status, watch):
        app.command()(command)
