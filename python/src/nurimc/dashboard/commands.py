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

from ..core.buscore import BusCore
from ..procedures.config import BACKUP_FORMAT
from ..procedures.motor import MotorProcedures
from ..procedures.settings import SETTINGS, setting
from ..protocol import BAUD_RATES, FieldRangeError

MAX_STEP_SECONDS = 10.0
LARGEST = 1e9  # no field of any command comes near this; larger numbers are refused before any arithmetic


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
class RunMotor:
    id: int
    rpm: float
    ramp: float


@dataclass(frozen=True, slots=True)
class Release:
    id: int


@dataclass(frozen=True, slots=True)
class HoldMotor:
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
class SetZero:
    id: int  # the current position becomes the device's zero (§15)


@dataclass(frozen=True, slots=True)
class ChangeId:
    id: int
    new_id: int


@dataclass(frozen=True, slots=True)
class ChangeBaud:
    id: int
    baudrate: int


@dataclass(frozen=True, slots=True)
class FactoryResetMotor:
    id: int


@dataclass(frozen=True, slots=True)
class Ports:
    pass


@dataclass(frozen=True, slots=True)
class OpenBus:
    port: str
    baudrate: int


@dataclass(frozen=True, slots=True)
class Frames:
    on: bool


Command = (
    Discover
    | Watch
    | Move
    | RunMotor
    | Release
    | HoldMotor
    | ReadSettings
    | WriteSetting
    | Step
    | Backup
    | Restore
    | EmergencyStop
    | Frames
    | SetZero
    | ChangeId
    | ChangeBaud
    | FactoryResetMotor
    | Ports
    | OpenBus
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
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise CommandError(f"{message.get('op')}: {name} must be a number, got {_show(value)}")
    try:
        result = float(value)
    except OverflowError:  # an integer too large for a float
        raise CommandError(f"{message.get('op')}: {name} is out of range, got {_show(value)}") from None
    if not math.isfinite(result) or abs(result) > LARGEST:
        raise CommandError(f"{message.get('op')}: {name} must be a number (finite, in range), got {_show(value)}")
    return result


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _optional_number(message: dict[str, Any], name: str) -> float | None:
    return None if message.get(name) is None else _number(message, name)


def _device_id(message: dict[str, Any]) -> int:
    value = _field(message, "id")
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 254:
        raise CommandError(f"{message.get('op')}: id must be a controller ID 0..254, got {_show(value)}")
    return value


def _ids(message: dict[str, Any]) -> tuple[int, ...]:
    values = _field(message, "ids")
    if not isinstance(values, list) or len(values) > 254:
        raise CommandError(f"{message.get('op')}: ids must be a list of controller IDs")
    return tuple(_device_id({"op": message.get("op"), "id": v}) for v in values)


def _ranges(check: Any, what: str = "") -> None:
    try:
        check()
    except (FieldRangeError, ValueError) as error:
        raise CommandError(str(error)) from None
    except (ArithmeticError, TypeError):  # e.g. a huge or non-finite number that reached the unit arithmetic
        raise CommandError(f"{what or 'value'}: not a valid value") from None


def _move(m: dict[str, Any]) -> Move:
    device_id = _device_id(m)
    degrees, rpm, seconds = _number(m, "degrees"), _optional_number(m, "rpm"), _optional_number(m, "seconds")
    relative = m.get("relative", False)
    if not isinstance(relative, bool):
        raise CommandError("move: relative must be true or false")
    if rpm is not None and rpm <= 0:
        raise CommandError(f"move: rpm must be above 0, got {rpm:g} (the direction comes from the target)")
    if seconds is not None and seconds <= 0:
        raise CommandError(f"move: seconds must be above 0, got {seconds:g}")
    _ranges(lambda: _checker.make_move_to(degrees, rpm, seconds))
    return Move(device_id, degrees, rpm, seconds, relative)


def _run(m: dict[str, Any]) -> RunMotor:
    device_id, rpm, ramp = _device_id(m), _number(m, "rpm"), _number(m, "ramp", 0.5)
    _ranges(lambda: _checker.make_run(rpm, ramp))
    return RunMotor(device_id, rpm, ramp)


def _write_setting(m: dict[str, Any]) -> WriteSetting:
    device_id, name, value = _device_id(m), _field(m, "name"), _field(m, "value")
    if not isinstance(name, str):
        raise CommandError(f"set: name must be a setting name, got {name!r}")
    try:
        s = setting(name)
    except KeyError as error:
        raise CommandError(str(error.args[0])) from None
    if s.command is None:
        raise CommandError(f"{s.name} is read-only")
    return WriteSetting(device_id, s.name, _setting_value(s, value, "set"))


def _setting_value(s: Any, value: Any, op: str) -> Any:
    """A setting's value: a word from its choices, or a finite number in its range (never text as a number)."""
    if s.spec.values:
        if not isinstance(value, str):
            raise CommandError(f"{op}: {s.name} must be one of {s.describe_range()}, got {_show(value)}")
    else:
        _number({"op": op, s.name: value}, s.name)
    _ranges(lambda: s.to_wire(value), f"{op}: {s.name} = {_show(value)}")
    return value


def _step(m: dict[str, Any]) -> Step:
    device_id, amplitude = _device_id(m), _number(m, "amplitude")
    rpm, duration = _number(m, "rpm", 60.0), _number(m, "duration", 2.0)
    if rpm <= 0:
        raise CommandError(f"step: rpm must be above 0, got {rpm:g}")
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
                _setting_value(s, value, f"restore: ID {device_id}")
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


def _change_id(m: dict[str, Any]) -> ChangeId:
    device_id = _device_id(m)
    new_id = _device_id({"op": "change_id", "id": _field(m, "new_id")})
    if new_id == device_id:
        raise CommandError(f"change_id: ID {device_id} already has that ID")
    return ChangeId(device_id, new_id)


def _change_baud(m: dict[str, Any]) -> ChangeBaud:
    rate = _field(m, "baudrate")
    if isinstance(rate, bool) or rate not in BAUD_RATES:
        raise CommandError(f"change_baud: baudrate must be one of {', '.join(map(str, BAUD_RATES))}")
    return ChangeBaud(_device_id(m), int(rate))


def _open_bus(m: dict[str, Any]) -> OpenBus:
    port, rate = _field(m, "port"), _field(m, "baudrate")
    if not isinstance(port, str) or not port.strip() or len(port) > 200:
        raise CommandError("open_bus: port must be a device path or URL, e.g. /dev/ttyUSB0")
    if isinstance(rate, bool) or rate not in BAUD_RATES:
        raise CommandError(f"open_bus: baudrate must be one of {', '.join(map(str, BAUD_RATES))}")
    return OpenBus(port.strip(), int(rate))


def _factory_reset(m: dict[str, Any]) -> FactoryResetMotor:
    device_id = _device_id(m)
    expected = f"RESET {device_id}"
    if m.get("confirm") != expected:
        raise CommandError(f"factory_reset: erases every setting of ID {device_id}; confirm by typing {expected!r}")
    return FactoryResetMotor(device_id)


_PARSERS: dict[str, Any] = {
    "discover": _discover,
    "watch": lambda m: Watch(_ids(m)),
    "move": _move,
    "run": _run,
    "release": lambda m: Release(_device_id(m)),
    "hold": lambda m: HoldMotor(_device_id(m)),
    "read_settings": lambda m: ReadSettings(_device_id(m)),
    "set": _write_setting,
    "step": _step,
    "backup": lambda m: Backup(_ids(m)),
    "restore": lambda m: Restore(check_backup(_field(m, "document"))),
    "estop": lambda m: EmergencyStop(),
    "frames": _frames,
    "set_zero": lambda m: SetZero(_device_id(m)),
    "change_id": _change_id,
    "change_baud": _change_baud,
    "factory_reset": _factory_reset,
    "ports": lambda m: Ports(),
    "open_bus": _open_bus,
    "tune": lambda m: _tune(m),  # Auto-tune: run by tune_panel.py
    "tune_cancel": lambda m: TuneCancel(),
}


# -- Auto-tune (issue 35; the worker's handler is tune_panel.run_tune) -------------------------
TUNE_MAX_TRIALS = 60  # the most trials the console asks for at once (each takes a few seconds)


@dataclass(frozen=True, slots=True)
class Tune:
    id: int
    loop: str
    goal: str | None
    travel: float
    max_rpm: float
    max_current: float
    trials: int
    max_overshoot: float | None
    max_settling: float | None


@dataclass(frozen=True, slots=True)
class TuneCancel:
    """Taken out of band by the server (the worker is busy with the tune)."""


def _tune(m: dict[str, Any]) -> Tune:
    """The `tune` op, checked as the library checks it (nothing reaches the bus when refused)."""
    from ..procedures.tuning import (
        DEFAULT_MAX_CURRENT,
        DEFAULT_MAX_RPM,
        DEFAULT_TRAVEL,
        GOALS,
        Envelope,
        TuneRefused,
        check_envelope,
        make_goal,
    )

    loop = m.get("loop", "position")
    goal = m.get("goal")
    if goal is not None and goal not in GOALS:
        raise CommandError(f"tune: goal must be one of {', '.join(GOALS)}, got {_show(goal)}")
    trials = _number(m, "trials", 12)
    if trials != int(trials) or not 2 <= trials <= TUNE_MAX_TRIALS:
        raise CommandError(f"tune: trials must be a whole number 2..{TUNE_MAX_TRIALS}, got {_show(m.get('trials'))}")
    command = Tune(
        _device_id(m),
        loop if isinstance(loop, str) else "",
        goal,
        _number(m, "travel", DEFAULT_TRAVEL),
        _number(m, "max_rpm", DEFAULT_MAX_RPM),
        _number(m, "max_current", DEFAULT_MAX_CURRENT),
        int(trials),
        _optional_number(m, "max_overshoot"),
        _optional_number(m, "max_settling"),
    )
    try:
        make_goal(command.goal, command.max_overshoot, command.max_settling)
        check_envelope(command.loop, Envelope(command.travel, command.max_rpm, command.max_current), command.trials)
    except TuneRefused as refused:
        raise CommandError(f"tune: {refused}") from None
    return command


def generation_of(message: Any) -> int | None:
    """The emergency-stop generation a page says it had seen when it sent the message, if any."""
    gen = message.get("gen") if isinstance(message, dict) else None
    if gen is None:
        return None
    if isinstance(gen, bool) or not isinstance(gen, int) or gen < 0:
        raise CommandError(f"gen must be a whole number >= 0, got {_show(gen)}")
    return gen


def parse(message: Any) -> Command:
    """A decoded JSON message -> a validated command (CommandError says what is wrong)."""
    if not isinstance(message, dict):
        raise CommandError("a message must be a JSON object with an 'op'")
    op = message.get("op")
    parser = _PARSERS.get(op) if isinstance(op, str) else None
    if parser is None:
        raise CommandError(f"unknown op {_show(op)}; ops: {', '.join(_PARSERS)}")
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
