"""Backup files (`nurimc backup` / `restore`, the console's backup): the format, read strictly,
written atomically.

A backup is what we wrote and nothing else: a JSON object with `format` ("nurimc-backup/1"),
`protocol`, `time` and `motors`, each motor `id`, `baudrate`, `product` and `settings` (physical
units, as `nurimc get` shows them). Anything else is refused with one line naming the file, the
motor and the field. Writes go to a temporary file beside the target, then a rename: a crash
leaves the old file or the new one, and the temporary file is removed on any failure.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..inputs import Rounded, field_value, integer, json_document, show
from ..protocol import BAUD_RATES, PRODUCTS
from .settings import SETTINGS

FORMAT = "nurimc-backup/1"
SIZE_LIMIT = 1 << 20  # bytes; a backup of 255 motors is about 150 kB
MAX_MOTORS = 255
TOP_KEYS = ("format", "protocol", "time", "motors")
MOTOR_KEYS = ("id", "baudrate", "product", "settings")


class BackupError(InputError):
    """A backup file or document that is not one we wrote; the message names file, motor and field."""


def check(document: object, source: str = "backup") -> dict[str, Any]:
    """The document as a clean backup (names canonical, numbers as the wire holds them), or
    BackupError naming `source`, the motor and the field."""
    try:
        return _check(document, source)
    except BackupError:
        raise
    except InputError as error:  # a value refused by nurimc.inputs: its message already names the field
        raise BackupError(str(error)) from None


def _check(document: object, source: str) -> dict[str, Any]:
    if not isinstance(document, dict):
        raise BackupError(f"{source}: not a nurimc backup (the top level is {_kind(document)}, not an object)")
    if document.get("format") != FORMAT:
        raise BackupError(f"{source}: not a nurimc backup (format {show(document.get('format'))}, expected {FORMAT!r})")
    _only(document, TOP_KEYS, source)
    for key in ("protocol", "time"):
        if key in document and not isinstance(document[key], str):
            raise BackupError(f"{source}: {key} is {_kind(document[key])}; give text")
    motors = document.get("motors")
    if not isinstance(motors, list):
        raise BackupError(f"{source}: motors is {_kind(motors)}; give a list of motors")
    if not 1 <= len(motors) <= MAX_MOTORS:
        raise BackupError(f"{source}: motors holds {len(motors)} entries; give 1..{MAX_MOTORS}")
    clean: list[dict[str, Any]] = []
    seen: set[int] = set()
    for index, entry in enumerate(motors):
        motor = _motor(entry, f"{source}: motors[{index}]")
        if motor["id"] in seen:
            raise BackupError(f"{source}: motors[{index}]: ID {motor['id']} appears twice")
        seen.add(motor["id"])
        clean.append(motor)
    return {**{k: document[k] for k in ("protocol", "time") if k in document}, "format": FORMAT, "motors": clean}


def _motor(entry: object, where: str) -> dict[str, Any]:
    if not isinstance(entry, dict):
        raise BackupError(f"{where}: {_kind(entry)}, not a motor (an object with {', '.join(MOTOR_KEYS)})")
    if isinstance(entry.get("id"), str):  # we write numbers; text ("1") is not a file we wrote
        raise BackupError(f"{where}: id {show(entry['id'])} is text; give a number")
    device_id = integer(entry.get("id"), f"{where}: id", 0, 254)
    where = f"{where} (ID {device_id})"
    _only(entry, MOTOR_KEYS, where)
    motor: dict[str, Any] = {"id": device_id}
    if "baudrate" in entry:
        if isinstance(entry["baudrate"], str):
            raise BackupError(f"{where}: baudrate {show(entry['baudrate'])} is text; give a number")
        rate = integer(entry["baudrate"], f"{where}: baudrate", min(BAUD_RATES), max(BAUD_RATES), "bps")
        if rate not in BAUD_RATES:
            raise BackupError(f"{where}: baudrate {rate} bps is not one of {', '.join(map(str, BAUD_RATES))}")
        motor["baudrate"] = rate
    if "product" in entry:
        # the type first: a list or an object is unhashable, and `in` a dict would raise TypeError
        if not isinstance(entry["product"], str) or entry["product"] not in PRODUCTS:
            raise BackupError(f"{where}: product {show(entry['product'])} is not one of {', '.join(PRODUCTS)}")
        motor["product"] = entry["product"]
    settings = entry.get("settings")
    if not isinstance(settings, dict):
        raise BackupError(f"{where}: settings is {_kind(settings)}; give an object of setting: value")
    motor["settings"] = {
        # the name as JSON would write it: a key with a newline or a control character stays one line
        name: setting_value(name, value, f"{where}: settings.{name if name.isprintable() else show(name)}")
        for name, value in settings.items()
    }
    return motor


def setting_value(name: str, value: object, where: str) -> float | int | str:
    """One setting's value from a file: its name (a text) or a number already on the wire's grid."""
    s = SETTINGS.get(name)
    if s is None:
        raise BackupError(f"{where}: not a setting; settings: {', '.join(SETTINGS)}")
    if isinstance(value, str) and not s.spec.values:
        raise BackupError(f"{where}: {show(value)} is text; give a number")
    checked = field_value(value, where, s.spec, whole=s.spec.unit in ("count", ""))
    if not isinstance(checked, Rounded):
        return checked
    if checked.changed:
        raise BackupError(f"{where}: {show(value)} is between the wire's steps; the nearest is {checked.physical}")
    return checked.wire if s.spec.scale == 1 else checked.physical


def _only(mapping: dict[Any, Any], known: tuple[str, ...], where: str) -> None:
    unknown = [k for k in mapping if k not in known]
    if unknown:
        raise BackupError(f"{where}: unknown field {show(unknown[0])}; a backup holds {', '.join(known)}")


def _kind(value: object) -> str:
    names = {dict: "an object", list: "a list", str: "a text", bool: "a boolean", type(None): "null"}
    return names.get(type(value), "a number") if not isinstance(value, str) else f"the text {show(value)}"


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise ValueError(f"the key {key!r} appears twice")
        result[key] = value
    return result


def load(path: str | Path) -> dict[str, Any]:
    """Read and check a backup file (BackupError naming the file if it is not one we wrote;
    OSError if it cannot be read)."""
    with open(path, "rb") as file:
        data = file.read(SIZE_LIMIT + 1)
    if len(data) > SIZE_LIMIT:
        raise BackupError(f"{path}: larger than {SIZE_LIMIT} bytes; not a nurimc backup")
    document = json_document(data, str(path), "a nurimc backup", BackupError, _no_duplicates)
    return check(document, str(path))


def check_writable(path: str | Path) -> Path:
    """The target of a backup, refused before any bus traffic if it cannot be written there."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise BackupError(f"{path}: the folder {folder} does not exist")
    if target.is_dir():
        raise BackupError(f"{path}: is a folder; give a file name")
    try:  # the truth, not os.access (root passes it; /proc and read-only mounts still refuse)
        fd, probe = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.", suffix=".tmp")
    except OSError as error:
        raise BackupError(f"{path}: cannot write in the folder {folder} ({error.strerror})") from None
    os.close(fd)
    os.unlink(probe)
    return target


def save(document: dict[str, Any], path: str | Path) -> None:
    """Check the document, then write it atomically (temporary file + rename)."""
    write_atomic(check_writable(path), json.dumps(check(document, "backup to save"), indent=2) + "\n")


def write_atomic(path: Path, text: str) -> None:
    """Write beside `path` and rename over it; the temporary file never outlives this call."""
    mode = _mode_for(path)
    fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        os.fchmod(fd, mode)  # mkstemp makes 0600; the file gets the mode a plain write would give it
        with os.fdopen(fd, "w", encoding="utf-8") as file:
            file.write(text)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException:  # also Ctrl+C and SIGTERM: never leave the temporary file behind
        Path(temporary).unlink(missing_ok=True)
        raise


def _mode_for(path: Path) -> int:
    try:
        return path.stat().st_mode & 0o777  # replacing a file keeps its mode
    except OSError:
        mask = os.umask(0o022)  # read the umask (it can only be read by setting it), then put it back
        os.umask(mask)
        return 0o666 & ~mask
