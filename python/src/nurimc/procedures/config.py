"""Safe configuration: ID and baud changes that verify and recover, guarded factory reset,
backup and restore of every setting, and recovery of a runaway motor.

A controller never answers a settings command, so each change here is proven by reading
back (or, for ID and baud, by pinging at the new address) before it is reported done.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.actions import Procedure, Wait
from ..core.buscore import BusCore
from ..errors import ConfirmationRequired, IdInUse, InputError, NoAnswer, SettingNotApplied, UnexpectedAnswer
from ..protocol import (
    BAUD_RATES,
    DEVICE_DEFAULTS,
    PROTOCOL,
    Command,
    FactoryReset,
    RequestPing,
    SetBaud,
    SetControl,
    SetId,
    baud_index,
    product_line,
)
from . import backup as backup_file
from .collisions import IdShared, check_free, check_not_shared, ping_alone, shared_message
from .motor import VERIFY_WINDOW, MotorProcedures
from .settings import SETTINGS, Setting, confirmed_answer

BACKUP_FORMAT = backup_file.FORMAT


def _in_line(core: BusCore, command: Command) -> Command:
    """The command in the product line known for its ID (nurimc.procedures.products; MC if none is known):
    the same setting has another mode in another line, and an SM's ID and baud codes are disputed."""
    product = core.products.get(command.id, "mc")
    target = product_line(product)
    if target.key == "mc":
        return command
    if not target.has(command.name):
        raise InputError(f"ID {command.id} is an {target.title}: its line has no {command.name}; nothing was sent")
    converted = target.make(command.name, command.id, **command.fields())
    assert isinstance(converted, Command)
    return converted


def answers(core: BusCore, device_id: int, window: float = 0.0) -> Procedure[bool]:
    """Does device_id answer a ping (retrying for `window` seconds, e.g. while EEPROM is busy)?"""
    waited = 0.0
    while True:
        try:
            yield from core.ask(RequestPing(device_id), retries=1)
            return True
        except UnexpectedAnswer:
            return True  # something answers at that ID
        except NoAnswer:
            if waited >= window:
                return False
            yield Wait(0.05)
            waited += 0.05


def change_id(core: BusCore, old: int, new: int) -> Procedure[None]:
    """Give controller `old` the ID `new`; refused if `new` already answers."""
    if not 0 <= new <= 254:
        raise InputError(f"new ID {new} is out of range 0..254")
    if old == new:
        return
    if (yield from ping_alone(core, new)) != "none":
        raise IdInUse(f"ID {new} already answers at {core.baudrate} bps; pick a free ID (see `nurimc scan`)")
    answering = yield from ping_alone(core, old)
    if answering == "shared":  # a write to a shared ID changes them all: still shared (nurimc.procedures.collisions)
        raise IdShared(shared_message(old, core.baudrate) + "; nothing was written")
    if answering == "none":
        raise NoAnswer("request_ping", old, core.baudrate, core.retries + 1)
    # the core holds the next frame to either ID until the write is done
    yield from core.tell(_in_line(core, SetId(old, new)))
    if (yield from answers(core, new, VERIFY_WINDOW)):
        core.response_times.pop(old, None)
        if old in core.products:  # its product line moves with it
            core.products[new] = core.products.pop(old)
        return
    still_old = yield from answers(core, old)
    raise SettingNotApplied(
        f"ID {old} -> {new} did not take: "
        + (f"the controller still answers at ID {old}" if still_old else "it answers at neither ID; run `nurimc scan`")
    )


def change_baud(core: BusCore, device_id: int, rate: int) -> Procedure[int]:
    """Switch a controller (and the host) to `rate`, verify there; if it is lost, find it.

    Returns the rate the controller answers at (= rate on success). Raises SettingNotApplied
    if it stayed at the old rate or turned up elsewhere (the bus is then left at that rate).
    """
    try:
        index = baud_index(rate)
    except ValueError as err:
        raise InputError(str(err)) from None
    old = core.baudrate
    try:
        return (yield from _change_baud(core, device_id, rate, index, old))
    except (GeneratorExit, SettingNotApplied):  # closed: no I/O any more; not applied: the bus is where it says
        raise
    except BaseException as failure:  # an I/O error, a timeout or a cancellation: the host goes back (docs/drivers.md)
        if core.baudrate != old:
            yield from core.return_to_baud(old, failure)
        raise


def _change_baud(core: BusCore, device_id: int, rate: int, index: int, old: int) -> Procedure[int]:
    # an adapter that cannot run at the new rate would lose the controller: refused before anything is sent
    yield from core.check_rate(rate, f"ID {device_id} was not changed (at {rate} bps it would be out of reach)")
    answering = yield from ping_alone(core, device_id)
    if answering == "shared":
        raise IdShared(shared_message(device_id, old) + "; nothing was written")
    if answering == "none":
        raise NoAnswer("request_ping", device_id, old, core.retries + 1)
    yield from check_free(  # the target rate: no controller there may have this ID already
        core,
        device_id,
        rate,
        f"moving ID {device_id} there would make two controllers share it; nothing was written "
        f"(give one of them another ID first: nurimc --baud {rate} --id {device_id} set id N)",
    )
    command = _in_line(core, SetBaud(device_id, index))
    yield from core.tell(command)
    # The host's rate may change only once the frame has left the wire: a UART switched with
    # bytes still in its FIFO sends them at the new rate, and the controller never hears them.
    # (Not a settle time: the core holds every frame to this ID until its busy window ends.)
    yield Wait(core.timing.wire_time(command.SPEC.size + 4, core.baudrate) + core.timing.latency + core.timing.margin)
    yield from core.set_baud(rate)
    if (yield from answers(core, device_id, VERIFY_WINDOW)):
        return rate
    for candidate in (old, *[r for r in BAUD_RATES if r not in (old, rate)]):
        yield from core.set_baud(candidate)
        if (yield from answers(core, device_id)):
            raise SettingNotApplied(
                f"ID {device_id} did not move to {rate} bps; it answers at {candidate} bps (the bus is now there)"
            )
    yield from core.set_baud(old)
    raise SettingNotApplied(
        f"ID {device_id} is lost after the baud change: no answer at any rate; check wiring and power"
    )


def factory_reset(core: BusCore, device_id: int, confirm: bool = False, allow_shared: bool = False) -> Procedure[None]:
    """Restore the document's defaults. The controller comes back as ID 0 at 9,600 bps.

    Refused (IdInUse, nothing sent) when another controller already answers as ID 0 at 9,600
    bps, unless allow_shared: the two would share ID 0 (nurimc.procedures.collisions); and when several
    controllers share `device_id` (all of them would be reset)."""
    if not confirm:
        raise ConfirmationRequired(
            f"factory reset of ID {device_id} erases every setting (it returns as ID 0 at 9600 bps); "
            "pass confirm=True (CLI: --yes) to do it"
        )
    if device_id != 0xFF and not allow_shared:
        yield from check_not_shared(core, device_id)
        if not (device_id == 0 and core.baudrate == FACTORY_BAUD):
            yield from check_free(
                core,
                0,
                FACTORY_BAUD,
                "after the reset two controllers would share ID 0; nothing was sent. Give that controller another "
                "ID first (nurimc --baud 9600 --id 0 set id N) or disconnect it; to reset anyway: "
                "allow_shared=True (CLI: --allow-shared-id)",
            )
    # busy window for the ID and for ID 0 (docs/protocol.md)
    yield from core.tell(_in_line(core, FactoryReset(device_id)))
    core.response_times.pop(device_id, None)
    if device_id in core.products and device_id != 0xFF:  # it comes back as ID 0, the same line
        core.products[0] = core.products.pop(device_id)


#: The rate a controller comes back at after a factory reset (with ID 0).
FACTORY_BAUD = 9600


def recover_runaway(motor: MotorProcedures) -> Procedure[str]:
    """A motor that runs away (motor or encoder wired the other way round): release it and flip its
    control direction (the document's appendix). It is left released; re-enable with hold()."""
    yield from motor.core.tell(_in_line(motor.core, SetControl(motor.id, 1)))
    s = SETTINGS["direction"]
    answer = yield from confirmed_answer(motor.core, motor._request(s.request, s.name))  # flip what it holds
    flipped = "cw" if s.to_physical(answer.fields()[s.field]) == "ccw" else "ccw"
    yield from motor.set("direction", flipped)
    yield from motor.release()
    return flipped


def backup(motors: Sequence[MotorProcedures]) -> Procedure[dict[str, Any]]:
    """Every setting of every motor, as a JSON-ready document."""
    entries = []
    for motor in motors:
        settings = yield from motor.read_settings()
        entries.append(
            {"id": motor.id, "baudrate": motor.core.baudrate, "product": motor.profile.key, "settings": settings}
        )
    return {
        "format": BACKUP_FORMAT,
        "protocol": PROTOCOL,
        "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "motors": entries,
    }


class LineMismatch(InputError):
    """A backup of one product line restored onto a controller of another: refused before any write."""


def same_line(a: str, b: str) -> bool:
    """Two line keys that hold the same settings: equal, SA and RSA (the rule names an SA "rsa"),
    or the SM tables (the rule names them all "sm")."""
    return a == b or {a, b} <= {"rsa", "sa"} or (a.startswith("sm") and b.startswith("sm"))


def restore_check(motors: Sequence[MotorProcedures], document: dict[str, Any], force_line: bool = False) -> list[str]:
    """Everything a restore checks before its first write (docs/cli.md, "Restore is a transaction"):
    each backup motor's product line against the controller's line (LineMismatch unless
    `force_line`), and every value against the range its field has in the controller's line
    (InputError naming ID, setting, value and range). Returns one line per forced mismatch."""
    from .products import line_of_product

    document = backup_file.check(document)
    by_id = {m.id: m for m in motors}
    mismatches: list[str] = []
    problems: list[str] = []
    for entry in document["motors"]:
        motor = by_id.get(entry["id"])
        if motor is None:
            raise ValueError(f"the backup has ID {entry['id']}, which is not among the motors to restore")
        saved_line = line_of_product(entry.get("product") or "mc")
        if not same_line(saved_line, motor.line.key):
            mismatches.append(
                f"ID {motor.id}: the backup is of {entry.get('product', 'mc')} ({saved_line} line), "
                f"the controller is {motor.line.title} ({motor.line.key} line)"
            )
        problems += _out_of_range(motor, entry["settings"])
    if mismatches and not force_line:
        raise LineMismatch(
            f"{'; '.join(mismatches)}: refused before any write (the same bytes are other settings in another "
            "line); to write the backup's settings by name anyway, each checked against the controller's "
            "line, give --force-line"
        )
    if problems:
        raise InputError(f"{'; '.join(problems)}: nothing was written")
    return mismatches


def _out_of_range(motor: MotorProcedures, saved: dict[str, Any]) -> list[str]:
    problems = []
    for name, value in saved.items():
        s = SETTINGS.get(name)
        if s is None or s.command is None or name == "control" or not motor.line.has(s.command):
            continue
        target = next((f for f in motor.line.message_class(s.command).SPEC.fields if f.name == s.field), None)
        if target is None or target.scale != s.spec.scale or target.unit != s.spec.unit:
            problems.append(f"ID {motor.id} {name}: {motor.line.title} holds it otherwise (field, unit or scale)")
            continue
        wire = s.to_wire(value)
        if not target.min <= wire <= target.max:
            problems.append(f"ID {motor.id} {name}: {value} is outside {target.describe_range()} on {motor.line.title}")
    return problems


def restore(
    motors: Sequence[MotorProcedures], document: dict[str, Any], force_line: bool = False
) -> Procedure[list[str]]:
    """Write back every setting that differs (each write verified); returns what was changed.

    The document is checked whole first (BackupError naming the motor and field): nothing is
    written from a backup that is not one we wrote. What differs is judged from confirmed reads
    (two that agree), and settings written by one command (the gains) are written together with
    the backup's values, never with values read: noise cannot be written back (docs/library.md,
    Verified writes). Running it again after an interruption completes it (only what still
    differs is written). Before the first write, `restore_check`: a backup of another product
    line is refused (LineMismatch) unless `force_line`, and every value is checked against the
    range of the controller's line."""
    document = backup_file.check(document)
    restore_check(motors, document, force_line)  # the line and every value, before the first write
    by_id = {m.id: m for m in motors}
    changed: list[str] = []
    for entry in document["motors"]:
        changed += yield from _restore_motor(by_id[entry["id"]], entry["settings"])
    return changed


def _restore_motor(motor: MotorProcedures, saved: dict[str, Any]) -> Procedure[list[str]]:
    groups: dict[str, list[Setting]] = {}  # command -> the settings it writes
    for name in saved:
        s = SETTINGS.get(name)
        if s is None or not motor.line.has(s.command or ""):  # a setting its line lacks (docs/cli.md)
            continue
        if s.command is not None and name != "control":  # control is left as it is (safety)
            groups.setdefault(s.command, []).append(s)
    changed: list[str] = []
    for command_name, group in groups.items():
        current = yield from confirmed_answer(motor.core, motor._request(group[0].request, group[0].name))
        now = current.fields()
        wanted = {s.field: s.to_wire(saved[s.name]) for s in group}
        differing = [s for s in group if now[s.field] != wanted[s.field]]
        if not differing:
            continue
        spec = motor.line.message_class(command_name).SPEC
        fields = {
            f: wanted.get(f, now[f]) for f in spec.field_names
        }  # a field the backup lacks keeps its confirmed value
        first = differing[0]
        yield from motor.write_verified(first, motor._command(command_name, first.name, **fields), wanted[first.field])
        changed += [
            f"ID {motor.id} {s.name}: {s.to_physical(now[s.field])} -> {s.to_physical(wanted[s.field])}"
            for s in differing
        ]
    return changed


def save_backup(document: dict[str, Any], path: str | Path) -> None:
    """Check the document and write it atomically (nurimc.procedures.backup)."""
    backup_file.save(document, path)


def load_backup(path: str | Path) -> dict[str, Any]:
    """Read and check a backup file (nurimc.procedures.backup): BackupError (a ValueError) names the file,
    motor and field of anything it does not hold as we wrote it."""
    try:
        return backup_file.load(path)
    except OSError as err:
        raise backup_file.BackupError(f"cannot read backup {path}: {err.strerror or err}") from err


DEFAULTS = DEVICE_DEFAULTS
