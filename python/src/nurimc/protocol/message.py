"""The base of every message class: validation, encoding and views of the fields."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from .errors import FieldRangeError, FieldTypeError
from .frame import build_frame
from .schema import FieldSpec, Kind, MessageSpec
from .units import from_wire


def check_value(spec: MessageSpec, field: FieldSpec, value: object) -> int:
    """The value as an int, or an error naming message, field, value, range and unit."""
    if not isinstance(value, int) or isinstance(value, bool):
        raise FieldTypeError(
            f"{spec.name}.{field.name} = {value!r} is not an integer wire value; allowed: {field.describe_range()}",
            spec.name,
            field.name,
        )
    if not field.min <= value <= field.max:
        raise FieldRangeError(spec.name, field.name, value, field.describe_range())
    return value


def check_id(spec: MessageSpec, frame_id: object) -> int:
    if not isinstance(frame_id, int) or isinstance(frame_id, bool):
        raise FieldTypeError(f"{spec.name}.id = {frame_id!r} is not an integer", spec.name, "id")
    if not 0 <= frame_id <= spec.max_id:
        allowed = "0..255 (255 = broadcast)" if spec.max_id == 0xFF else "0..254 (no broadcast)"
        raise FieldRangeError(spec.name, "id", frame_id, allowed)
    return frame_id


class Message:
    """A message with its controller ID. Subclasses are generated from the spec."""

    __slots__ = ()
    SPEC: ClassVar[MessageSpec]
    id: int

    if TYPE_CHECKING:  # the generated dataclasses define the real constructors

        def __init__(self, id: int, *fields: int, **named: int) -> None: ...  # noqa: A002

    def encode(self) -> bytes:
        """The whole frame; raises EncodeError if the ID or a field is out of range."""
        spec = self.SPEC
        check_id(spec, self.id)
        values = [check_value(spec, f, getattr(self, f.name)) for f in spec.fields]
        return build_frame(self.id, spec.mode, spec.layout.pack(*values))

    @property
    def name(self) -> str:
        return self.SPEC.name

    @property
    def is_broadcast(self) -> bool:
        return self.id == 0xFF

    def fields(self) -> dict[str, int]:
        """Field values as raw wire integers, in wire order."""
        return {f.name: getattr(self, f.name) for f in self.SPEC.fields}

    def to_dict(self) -> dict[str, Any]:
        """The conformance form: {"id": .., "message": .., <fields>}."""
        return {"id": self.id, "message": self.SPEC.name, **self.fields()}

    def physical(self) -> dict[str, float | int | str]:
        """Field values in physical units (degrees, RPM, A, s, us, ratio) or value names."""
        out: dict[str, float | int | str] = {}
        for f in self.SPEC.fields:
            raw = getattr(self, f.name)
            names = dict(f.values)
            if raw in names:
                out[f.name] = names[raw]
            elif f.unit:
                out[f.name] = from_wire(raw, f.scale)
            else:
                out[f.name] = raw
        return out


class Command(Message):
    """Host -> controller; never answered. ID 0xFF (broadcast) reaches every controller."""

    __slots__ = ()
    KIND: ClassVar[Kind] = Kind.COMMAND


class Request(Message):
    """Host -> controller feedback request; the addressed controller answers."""

    __slots__ = ()
    KIND: ClassVar[Kind] = Kind.REQUEST


class Answer(Message):
    """Controller -> host."""

    __slots__ = ()
    KIND: ClassVar[Kind] = Kind.ANSWER
