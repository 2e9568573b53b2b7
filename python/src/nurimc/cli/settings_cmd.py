"""get, set, backup, restore, factory-reset: settings, always verified by reading back."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import typer
from rich.progress import Progress, TextColumn, TimeElapsedColumn

from ..drivers.sync import Bus
from ..errors import InputError
from ..inputs import UNIT_SHOWN, Rounded, field_value, integer, with_unit
from ..procedures import backup as backup_file
from ..procedures import config
from ..procedures.discovery import Progress as ScanProgress
from ..procedures.discovery import discover
from ..procedures.journal import RestoreJournal, incomplete_message
from ..procedures.motor import Motor
from ..procedures.products import UNKNOWN, detect_line
from ..procedures.settings import SETTINGS, Setting, setting
from .common import (
    EXIT_DEVICE,
    EXIT_OK,
    EXIT_USAGE,
    Options,
    SignedValuesCommand,
    check_baud,
    emit,
    err,
    fail,
    motor_for,
    note,
    one_id,
    open_bus,
    options,
    table,
)
from .i18n import tr

T = TypeVar("T")
NAMES = ", ".join([*SETTINGS, "id", "baud"])
#: what `set` can write: the read-only ones (firmware) are not offered
WRITABLE = ", ".join([*(name for name, s in SETTINGS.items() if s.command is not None), "id", "baud"])


def get(ctx: typer.Context, names: list[str] = typer.Argument(..., help=f"One or more of: {NAMES}.")) -> None:
    """Read settings, in physical units (one name, or several: get ratio resolution).

    Example: nurimc --port /dev/ttyUSB0 --id 1 get ratio
    """
    o = options(ctx)
    device_id = one_id(o)
    wanted = [name if name in ("id", "baud") else setting(name).name for name in names]  # all checked first
    results: list[dict[str, object]] = []
    lines: list[str] = []
    needs_bus = any(name not in ("id", "baud") for name in wanted)
    with open_bus(o) if needs_bus else contextlib.nullcontext() as bus:
        motor = motor_for(bus, o, device_id, acts=False) if bus is not None else None
        for name in wanted:
            if name in ("id", "baud"):
                value: object = device_id if name == "id" else o.baud
                results.append({"id": device_id, "name": name, "value": value})
                lines.append(str(value) if len(wanted) == 1 else f"{name} = {value}")
                continue
            s = setting(name)
            assert motor is not None
            got = motor.get(s.name)
            results.append({"id": device_id, "name": s.name, "value": got, "unit": s.unit})
            lines.append(f"{s.name} = {_shown(s, got)}")
    if len(results) == 1:  # one name: one document, one line, as always
        emit(o, results[0], lines[0])
        return
    if o.json:
        emit(o, results)
    else:
        for line in lines:
            emit(o, None, line)


def set_(
    ctx: typer.Context,
    name: str = typer.Argument(..., help=f"One of: {WRITABLE}."),
    value: str = typer.Argument(..., help="In physical units: 12.5 (ratio 12.5:1), 300us, 2.5A, cw, relative, 115200."),
) -> None:
    """Write one setting and verify it by reading it back.

    Example: nurimc --port /dev/ttyUSB0 --id 1 set response-time 300us
    """
    o = options(ctx)
    device_id = one_id(o)
    if name == "id":
        new = _checked(lambda: integer(value, "id", 0, 254))
    elif name == "baud":
        rate = check_baud(value, "baud")
    else:
        s = setting(name)
        if s.command is None:
            fail(f"{s.name} is read-only")
        wanted = _checked(lambda: field_value(value, s.name, s.spec, whole=s.spec.unit == "count"))
        if isinstance(wanted, Rounded) and wanted.changed:
            note(wanted.note(s.name, UNIT_SHOWN.get(s.spec.unit, "")))
    with open_bus(o) as bus:
        motor = motor_for(bus, o, device_id)  # its product line: the same setting has other codes in others
        if name == "id":
            bus.run(config.change_id(bus.core, device_id, new))
            emit(
                o,
                {"id": new, "name": "id", "value": new, "verified": True},
                f"ID {device_id} is now ID {new} (verified)",
            )
            return
        if name == "baud":
            bus.run(config.change_baud(bus.core, device_id, rate))
            emit(
                o,
                {"id": device_id, "name": "baud", "value": rate, "verified": True},
                f"ID {device_id} now talks at {rate} bps (verified); use --baud {rate} from now on",
            )
            return
        written = motor.set(s.name, wanted if isinstance(wanted, str) else wanted.physical)
    extra = {"asked": wanted.asked} if isinstance(wanted, Rounded) and wanted.changed else {}
    emit(
        o,
        {"id": device_id, "name": s.name, "value": written, "unit": s.unit, "verified": True, **extra},
        f"{s.name} = {_shown(s, written)} (verified)",
    )


def _checked(check: Callable[[], T]) -> T:
    try:
        return check()
    except InputError as error:
        fail(str(error))


def _shown(s: Setting, value: object) -> str:
    return with_unit(value, UNIT_SHOWN.get(s.spec.unit, "")) if isinstance(value, int | float) else str(value)


def _motors_on_bus(bus: Bus, o: Options) -> list[Motor]:
    if o.ids:
        return [motor_for(bus, o, i, acts=False) for i in o.ids]
    columns = (TextColumn("{task.description}"), TimeElapsedColumn())
    with Progress(*columns, console=err, disable=o.json, transient=True) as bar:  # discovery takes seconds: live
        task = bar.add_task(tr(f"looking for controllers at {o.baud} bps"), total=None)

        def show(event: object) -> None:
            if isinstance(event, ScanProgress):
                at = f", ID {event.walking_id}" if event.walking_id is not None else ""
                bar.update(task, description=tr(f"{o.baud} bps{at}: {len(event.found)} found"))

        found = bus.run(discover(bus.core, [o.baud]), on_note=show)
    if not found:
        fail(f"no controller answers at {o.baud} bps; give --baud or --id", EXIT_DEVICE)
    return [bus.motor(f.id, o.product if o.product_given else None) for f in found]  # the line found


def backup(ctx: typer.Context, file: str = typer.Argument(..., help="JSON file to write.")) -> None:
    """Save every setting of every motor (--id, or all found at --baud) to a file.

    Example: nurimc --port /dev/ttyUSB0 backup robot.json
    """
    o = options(ctx)
    backup_file.check_writable(file)  # before any bus traffic
    with open_bus(o) as bus:
        motors = _motors_on_bus(bus, o)
        document = bus.run(config.backup([m.procedures for m in motors]))
    config.save_backup(document, file)
    emit(o, {"file": file, "ids": [m.id for m in motors]}, f"saved {len(motors)} motor(s) to {file}")


def restore(
    ctx: typer.Context,
    file: str = typer.Argument(..., help="A file written by backup."),
    force_line: bool = typer.Option(
        False,
        "--force-line",
        help="Restore a backup of another product line: its settings by name, each checked for the controller's line.",
    ),
) -> None:
    """Write back every setting that differs from a backup (each verified).

    Example: nurimc --port /dev/ttyUSB0 restore robot.json
    """
    o = options(ctx)
    document = config.load_backup(file)
    ids = [entry["id"] for entry in document.get("motors", [])]
    with open_bus(o) as bus:
        motors = [restore_target(bus, o, entry) for entry in document.get("motors", [])]
        try:  # the line and every value first: a refusal leaves no journal and writes nothing
            forced = config.restore_check([m.procedures for m in motors], document, force_line)
        except InputError as error:
            fail(str(error), EXIT_USAGE)
        for line in forced:  # the summary of what --force-line does
            err.print(f"{tr('warning:')} {tr(f'{line}; --force-line: writing its settings by name')}", soft_wrap=True)
        journal = restore_journal(o, ids, file)  # docs/cli.md: an interrupted restore is found next time
        changed = bus.run(config.restore([m.procedures for m in motors], document, force_line))
        journal.done(ids)
    rows = table(f"restored from {file}", "change")
    for line in changed or ["nothing differed"]:
        rows.add_row(line)
    emit(o, {"file": file, "changed": changed}, rows)


def restore_target(bus: Bus, o: Options, entry: dict[str, object]) -> Motor:
    """The controller a backup motor is restored onto, in the line it answers as (--product if
    given): never the backup's word for it, which is what restore checks against."""
    device_id = entry["id"]
    assert isinstance(device_id, int)
    if o.product_given:
        return bus.motor(device_id, o.product)
    product = entry.get("product")
    if isinstance(product, str):  # kept if the controller answers in its line (blmc-h stays blmc-h)
        bus.core.products[device_id] = product
    identified = bus.run(detect_line(bus.core, device_id))
    if identified.line == UNKNOWN:
        fail(
            f"ID {device_id} at {bus.baudrate} bps answers none of the questions that tell product lines apart "
            "(or does not answer): give --product (mc, blmc-h, rsa, rsavw, sa, sm-cs, sm-readme)",
            EXIT_USAGE,
        )
    return bus.motor(device_id)


def restore_journal(o: Options, ids: list[int], file: str) -> RestoreJournal:
    """Say what an earlier restore left unfinished, then mark these IDs as being restored from `file`."""
    journal = RestoreJournal(o.port or os.environ.get("NURIMC_PORT", ""))
    target = str(Path(file).resolve())
    for earlier in sorted({p for p in map(journal.pending, ids) if p is not None}):
        then = "completing it now" if earlier == target else f"restoring {file} instead replaces it"
        err.print(f"{tr('note:')} {tr(f'{incomplete_message(earlier)}; {then}')}", soft_wrap=True, markup=False)
    try:
        journal.begin(ids, file)
    except OSError as error:  # a read-only home: the restore still runs, unguarded, and says so
        journal.enabled = False
        unguarded = (
            f"cannot keep a restore journal in {journal.directory} ({error.strerror or error}): "
            "an interruption will not be detected; set NURIMC_STATE_DIR to a writable folder"
        )
        err.print(
            f"{tr('warning:')} {tr(unguarded)}",
            soft_wrap=True,
            markup=False,
        )
    return journal


def factory_reset(
    ctx: typer.Context,
    yes: bool = typer.Option(False, "--yes", help="Do not ask."),
    allow_shared_id: bool = typer.Option(
        False,
        "--allow-shared-id",
        help="Reset even when another controller already answers as ID 0 at 9600 bps (the two then share ID 0).",
    ),
) -> None:
    """Erase every setting of one controller: it returns as ID 0 at 9600 bps.

    Example: nurimc --port /dev/ttyUSB0 --id 3 factory-reset --yes
    """
    o = options(ctx)
    device_id = one_id(o)
    if not yes:
        if not sys.stdin.isatty():
            fail(
                "factory reset erases every setting and needs confirming, but stdin is not a terminal to ask "
                f"on; to confirm, run: nurimc ... --id {device_id} factory-reset --yes"
            )
        if not typer.confirm(tr(f"Erase every setting of ID {device_id}? It will come back as ID 0 at 9600 bps")):
            err.print(tr("not reset: answered no (nothing was sent)"))
            raise typer.Exit(EXIT_OK)
    with open_bus(o) as bus:
        motor_for(bus, o, device_id)  # its product line: factory reset is 10 on MC, 0D on RSA, 09 on SM
        bus.run(config.factory_reset(bus.core, device_id, confirm=True, allow_shared=allow_shared_id))
    emit(
        o,
        {"id": device_id, "reset": True, "now": {"id": 0, "baud": 9600}},
        f"ID {device_id} reset to factory defaults: it is now ID 0 at 9600 bps",
    )


def register(app: typer.Typer) -> None:
    app.command()(get)
    app.command(name="set", cls=SignedValuesCommand, context_settings={"ignore_unknown_options": True})(
        set_
    )  # `set ratio -5`: a value
    app.command()(backup)
    app.command()(restore)
    app.command(name="factory-reset")(factory_reset)
