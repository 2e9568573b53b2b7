"""Types that describe the protocol: what the generated tables are made of."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from enum import StrEnum


class Kind(StrEnum):
    COMMAND = "command"  # host -> controller, never answered
    REQUEST = "request"  # host -> controller, answered
    ANSWER = "answer"  # controller -> host


@dataclass(frozen=True, slots=True)
class FieldSpec:
    """One field on the wire: its width, allowed range and physical unit."""

    name: str
    width: int  # bytes, big-endian
    min: int
    max: int
    unit: str = ""  # "deg", "rpm", "A", "s", "us", "ratio", "count" or "" (no unit)
    scale: float = 1  # physical value = wire value * scale
    values: tuple[tuple[int, str], ...] = ()  # names of enumerated values
    doc: str = ""

    def describe_range(self) -> str:
        """`1..65533 (0.1..6553.3 rpm)`: the wire range and, where scaled, its physical range."""
        text = f"{self.min}..{self.max}"
        if self.unit and self.scale != 1:
            from .units import from_wire  # local: units imports nothing of ours but keeps schema tiny

            text += f" ({from_wire(self.min, self.scale)}..{from_wire(self.max, self.scale)} {self.unit})"
        elif self.unit and self.unit != "count":
            text += f" {self.unit}"
        if self.values:
            text += " (" + ", ".join(f"{v} {n}" for v, n in self.values) + ")"
        return text


@dataclass(frozen=True, slots=True)
class MessageSpec:
    """One message type: mode byte, size byte and fields in wire order."""

    name: str
    kind: Kind
    mode: int
    size: int
    section: int
    title: str
    fields: tuple[FieldSpec, ...]
    answer: str | None = None  # for requests: the answer's name
    request: str | None = None  # for answers: the request's name
    max_id: int = 0xFE  # 0xFF (broadcast) is allowed for commands only
    layout: struct.Struct = field(init=False, repr=False, compare=False)
    #: the fields' names, in wire order (worked out once: every reading's fields() uses them)
    field_names: tuple[str, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        codes = "".join("B" if f.width == 1 else "H" for f in self.fields)
        object.__setattr__(self, "layout", struct.Struct(">" + codes))
        object.__setattr__(self, "field_names", tuple(f.name for f in self.fields))


@dataclass(frozen=True, slots=True)
class ProductSpec:
    """A product line speaking this protocol, with its assumed defaults."""

    key: str
    title: str
    motor: str
    resolution_unit: str
    max_rated_current: int
    defaults: tuple[tuple[str, int], ...]


@dataclass(frozen=True, slots=True)
class LineSpec:
    """A product line: which message each mode byte means (spec/lines.json)."""

    key: str
    title: str
    what: str
    source: str
    products: tuple[str, ...]
    messages: tuple[MessageSpec, ...]
