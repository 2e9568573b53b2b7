"""Every controller setting by name, in physical units: one table for library, CLI and console.

A setting is read with its feedback request and written with its command; settings that
share a command (Kp, Ki, Kd and rated current) are written together, read-modify-write.

Verified writes (docs/library.md): an 8-bit checksum lets some noise through, so a write built
from a read takes that read only once two reads agree (`confirmed_answer`), and a write is done
only when a read-back shows every field it wrote (`fields_differ`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..core.actions import Procedure
from ..core.buscore import BusCore
from ..errors import UnconfirmedRead, UnknownSetting, ValueOutOfRange
from ..protocol import SPECS, Command, FieldSpec, Message, MessageSpec, Request, units
from ..protocol._settings import SETTINGS as _SPEC_SETTINGS

_INPUT_RULES = {s["name"]: s["input"] for s in _SPEC_SETTINGS}


@dataclass(frozen=True, slots=True)
class Setting:
    name: str  # the CLI's name, e.g. "position-kp"
    answer: str  # answer message, e.g. "position_gains"
    field: str  # its field, e.g. "kp"
    command: str | None  # command that writes it (None: read-only)
    doc: str

    @property
    def spec(self) -> FieldSpec:
        return next(f for f in self.answer_spec.fields if f.name == self.field)

    @property
    def answer_spec(self) -> MessageSpec:
        return SPECS[self.answer]

    @property
    def request(self) -> str:
        request = SPECS[self.answer].request
        assert request is not None
        return request

    @property
    def input(self) -> str:
        """How a typed value becomes a wire value: integer, quantize or choice (spec/settings.json)."""
        return str(_INPUT_RULES[self.name])

    @property
    def unit(self) -> str:
        return {"us": "µs", "ratio": ":1", "count": ""}.get(self.spec.unit, self.spec.unit)

    def to_wire(self, value: object) -> int:
        """A physical value (number, '300us', 'cw', 'on', '12.5') -> the wire integer, range-checked."""
        spec = self.spec
        names = {name: raw for raw, name in spec.values}
        if isinstance(value, str) and value.strip().lower() in names:
            return names[value.strip().lower()]
        try:
            number = units.parse_quantity(value, spec.unit) if isinstance(value, str) else float(value)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise ValueOutOfRange(self.name, "value", value, self.describe_range()) from None
        if isinstance(value, bool) or not math.isfinite(number):
            raise ValueOutOfRange(self.name, "value", value, self.describe_range())
        if self.input == "quantize":
            raw = units.to_wire(number, spec.scale)
        elif number.is_integer():  # integer and choice: a fraction is refused (spec/settings.json)
            raw = int(number)
        else:
            raise ValueOutOfRange(self.name, "value", value, self.describe_range())
        if not spec.min <= raw <= spec.max:
            raise ValueOutOfRange(self.name, "value", value, self.describe_range())
        return raw

    def to_physical(self, raw: int) -> float | int | str:
        names = dict(self.spec.values)
        if raw in names:
            return names[raw]
        return units.from_wire(raw, self.spec.scale) if self.spec.unit else raw

    def describe_range(self) -> str:
        spec = self.spec
        if spec.values:
            return " or ".join(name for _, name in spec.values)
        low, high = self.to_physical(spec.min), self.to_physical(spec.max)
        return f"{low}..{high}{' ' + self.unit if self.unit else ''}"


#: Every setting, in the spec's order, from the generated spec (spec/settings.json): names,
#: the command that writes each, the answer and field that read it, and what it is.
SETTINGS: dict[str, Setting] = {
    s["name"]: Setting(s["name"], s["answer"], s["field"], s["command"], s["doc"]) for s in _SPEC_SETTINGS
}


def setting(name: str) -> Setting:
    """Look a setting up by name ('position_kp' and 'position-kp' both work)."""
    key = name.strip().lower().replace("_", "-")
    try:
        return SETTINGS[key]
    except KeyError:
        raise UnknownSetting(f"unknown setting {name!r}; settings: {', '.join(SETTINGS)}, id, baud") from None


#: Reads taken at most to find two that agree before a write is built from them.
CONFIRM_READS = 4


def confirmed_answer(core: BusCore, request: Request) -> Procedure[Message]:
    """The answer to `request` once two reads agree (at most CONFIRM_READS reads).

    Noise that keeps the checksum changes an answer at random, so two reads that agree are the
    controller's values; a write built from one read could carry the noise back into the
    controller's EEPROM (issue 21: one noisy answer rewrote three gains)."""
    seen: list[Message] = []
    for _ in range(CONFIRM_READS):
        answer: Message = yield from core.ask(request)
        if answer in seen:
            return answer
        seen.append(answer)
    raise UnconfirmedRead(
        f"ID {request.id}: {CONFIRM_READS} reads of {request.name} all differ ({', '.join(_values(a) for a in seen)}): "
        "noise on the bus gets past the checksum, so nothing was written; check termination, grounding and the "
        "cable, then try again"
    )


def fields_differ(command: Command, answer: Message) -> dict[str, tuple[int, int]]:
    """Every field the command wrote that the read-back answer does not show: {field: (wrote, read)}."""
    got = answer.fields()
    return {name: (value, got[name]) for name, value in command.fields().items() if got.get(name) != value}


def _values(answer: Message) -> str:
    return " ".join(f"{k}={v}" for k, v in answer.fields().items())
