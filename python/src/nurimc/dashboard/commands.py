"""What a browser may ask, validated before anything reaches the bus.

Each websocket message is a JSON object {"op": ..., "req": n, ...}. `parse` turns it into one
of the command dataclasses below or raises CommandError with a message for the user. Ranges are
checked with the library's own builders and setting table, so the console refuses exactly
what the CLI and library refuse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ..client.core import BusCore
from ..config import BACKUP_FORMAT
from ..motor import MotorProcedures
from ..protocol import BAUD_RATES, FieldRangeError
from ..settings import SETTINGS, setting

MAX_STEP_SECONDS = 10.0


class CommandError(ValueError):
    """A message from the page that cannot be carried out as given."""


@dataclass(frozen=True, slots=True)
class Discover:
    rates: tuple[int, ...] | None  # None: all 18


@dataclass(frozen=True, slots=True)
class Watch:
    ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class Move:
    id: int
    degrees: float
    rpm: float | None
    seconds: float | None
    relative: bool


@dataclass(frozen=True, slots=True)
class Run:
    id: int
    rpm: float
    ramp: float


@dataclass(frozen=True, slots=True)
class Release:
    id: int


@dataclass(frozen=True, slots=True)
class Hold:
    id: int


@dataclass(frozen=True, slots=True)
class ReadSettings:
    id: int


@dataclass(frozen=True, slots=True)
class WriteSetting:
    id: int
    name: str
    value: float | int | str


@dataclass(frozen=True, slots=True)
class Step:
    id: int
    amplitude: float  # degrees from where the motor is
    rpm: float
    duration: float  # seconds to record


@dataclass(frozen=True, slots=True)
class Backup:
    ids: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class Restore:
    document: dict[str, Any]


@dataclass(frozen=True, slots=True)
class EmergencyStop:
    pass


@dataclass(frozen=True, slots=True)
class Frames:
    on: bool


Command = (
    Discover
    | Watch
    | Move
    | Run
    | Release
    | Hold
    | ReadSettings
    | WriteSetting
    | Step
    | Backup
    | Restore
    | EmergencyStop
    | Frames
)

_checker = MotorProcedures(BusCore(), 1)  # its builders only check ranges; it never touches a bus


def _field(message: dict[str, Any], name: str) -> Any:
    if name not in message:
        raise CommandError(f"{message.get('op')}: missing {name!r}")
    return message[name]


def _number(message: dict[str, Any], name: str, default: float | None = None) -> float:
    value = message.get(name, default)
    if value is None:
        raise CommandError(f"{message.get('op')}: missing {name!r}")
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise CommandError(f"{message.get('op')}: {name} must be a number, got {value!r}")
    return float(value)


def _optional_number(message: dict[str, Any], name: str) -> float | None:
    return None if message.get(name) is None else _number(message, name)


def _device_id(message: dict[str, Any]) -> int:
    value = _field(message, "id")
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 254:
        raise CommandError(f"{message.get('op')}: id must be a controller ID 0..254, got {value!r}")
    return value


def _ids(message: dict[str, Any]) -> tuple[int, ...]:
    values = _field(message, "ids")
    if not isinstance(values, list) or len(values) > 254:
        raise CommandError(f"{message.get('op')}: ids must be a list of controller IDs")
    return tuple(_device_id({"op": message.get("op"), "id": v}) for v in values)


def _ranges(check: Any) -> None:
    try:
        check()
    except FieldRangeError as error:
        raise CommandError(str(error)) from None
    except ValueError as error:
        raise CommandError(str(error)) from None


def _move(m: dict[str, Any]) -> Move:
    device_id = _device_id(m)
    degrees, rpm, seconds = _number(m, "degrees"), _optional_number(m, "rpm"), _optional_number(m, "seconds")
    relative = m.get("relative", False)
    if not isinstance(relative, bool):
        raise CommandError("move: relative must be true or false")
    _ranges(lambda: _checker.make_move_to(degrees, rpm, seconds))
    return Move(device_id, degrees, rpm, seconds, relative)


def _run(m: dict[str, Any]) -> Run:
    device_id, rpm, ramp = _device_id(m), _number(m, "rpm"), _number(m, "ramp", 0.5)
    _ranges(lambda: _checker.make_run(rpm, ramp))
    return Run(device_id, rpm, ramp)


def _write_setting(m: dict[str, Any]) -> WriteSetting:
    device_id, name, value = _device_id(m), _field(m, "name"), _field(m, "value")
    if not isinstance(name, str):
        raise CommandError(f"set: name must be a setting name, got {name!r}")
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise CommandError(f"set: value must be a number or a word, got {value!r}")
    try:
        s = setting(name)
    except KeyError as error:
        raise CommandError(str(error.args[0])) from None
    if s.command is None:
        raise CommandError(f"{s.name} is read-only")
    _ranges(lambda: s.to_wire(value))
    return WriteSetting(device_id, s.name, value)


def _step(m: dict[str, Any]) -> Step:
    device_id, amplitude = _device_id(m), _number(m, "amplitude")
    rpm, duration = _number(m, "rpm", 60.0), _number(m, "duration", 2.0)
    if amplitude == 0:
        raise CommandError("step: amplitude must not be 0 degrees")
    if not 0.2 <= duration <= MAX_STEP_SECONDS:
        raise CommandError(f"step: duration must be 0.2..{MAX_STEP_SECONDS} s, got {duration}")
    _ranges(lambda: _checker.make_move_to(amplitude, rpm, None))
    return Step(device_id, amplitude, rpm, duration)


def check_backup(document: Any) -> dict[str, Any]:
    """A restore document: our format, motors with valid IDs, every setting known and in range."""
    if not isinstance(document, dict) or document.get("format") != BACKUP_FORMAT:
        raise CommandError(f"restore: not a nurimc backup (expected format {BACKUP_FORMAT!r})")
    motors = document.get("motors")
    if not isinstance(motors, list) or not motors:
        raise CommandError("restore: the backup lists no motors")
    for entry in motors:
        if not isinstance(entry, dict) or not isinstance(entry.get("settings"), dict):
            raise CommandError("restore: each motor needs an id and settings")
        device_id = _device_id({"op": "restore", "id": entry.get("id")})
        for name, value in entry["settings"].items():
            s = SETTINGS.get(name)
            if s is None:
                raise CommandError(f"restore: ID {device_id} has unknown setting {name!r}")
            if s.command is not None and name != "control":
                _ranges(lambda s=s, value=value: s.to_wire(value))
    return document


def _discover(m: dict[str, Any]) -> Discover:
    rates = m.get("rates")
    if rates is None:
        return Discover(None)
    if not isinstance(rates, list) or not rates or any(r not in BAUD_RATES or isinstance(r, bool) for r in rates):
        raise CommandError(f"discover: rates must be a list of {', '.join(map(str, BAUD_RATES))}")
    return Discover(tuple(rates))


def _frames(m: dict[str, Any]) -> Frames:
    on = _field(m, "on")
    if not isinstance(on, bool):
        raise CommandError("frames: on must be true or false")
    return Frames(on)


_PARSERS: dict[str, Any] = {
    "discover": _discover,
    "watch": lambda m: Watch(_ids(m)),
    "move": _move,
    "run": _run,
    "release": lambda m: Release(_device_id(m)),
    "hold": lambda m: Hold(_device_id(m)),
    "read_settings": lambda m: ReadSettings(_device_id(m)),
    "set": _write_setting,
    "step": _step,
    "backup": lambda m: Backup(_ids(m)),
    "restore": lambda m: Restore(check_backup(_field(m, "document"))),
    "estop": lambda m: EmergencyStop(),
    "frames": _frames,
}


def parse(message: Any) -> Command:
    """A decoded JSON message -> a validated command (CommandError says what is wrong)."""
    if not isinstance(message, dict):
        raise CommandError("a message must be a JSON object with an 'op'")
    op = message.get("op")
    parser = _PARSERS.get(op) if isinstance(op, str) else None
    if parser is None:
        raise CommandError(f"unknown op {op!r}; ops: {', '.join(_PARSERS)}")
    command: Command = parser(message)
    return command


def settings_catalogue() -> list[dict[str, Any]]:
    """Every setting for the page's editor: name, unit, range, choices, whether it can be written."""
    out = []
    for s in SETTINGS.values():
        spec = s.spec
        out.append(
            {
                "name": s.name,
                "doc": s.doc,
                "unit": s.unit,
                "range": s.describe_range(),
                "choices": [name for _, name in spec.values],
                "min": s.to_physical(spec.min) if not spec.values else None,
                "max": s.to_physical(spec.max) if not spec.values else None,
                "step": spec.scale if spec.unit else 1,
                "writable": s.command is not None,
            }
        )
    return out
