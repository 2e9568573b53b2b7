"""The base of every message class: validation, encoding and views of the fields."""

from __future__ import annotations

from operator import itemgetter
from typing import TYPE_CHECKING, Any, ClassVar, Self

from .errors import FieldRangeError, FieldTypeError
from .frame import build_frame
from .schema import FieldSpec, Kind, MessageSpec
from .units import from_wire

try:  # namedtuple's field getter, in C; private to the standard library, hence the fallback
    from collections import _tuplegetter  # type: ignore[attr-defined]
except ImportError:  # pragma: no cover - other Python implementations

    def _tuplegetter(index: int, doc: str) -> Any:
        return property(itemgetter(index), doc=doc)


def field_getter(index: int, doc: str) -> Any:
    """A read-only attribute reading item `index` of the message tuple."""
    return _tuplegetter(index, doc)


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


class Message(tuple[int, ...]):
    """A message with its controller ID. Subclasses are generated from the spec.

    An immutable tuple underneath, (id, field, field, ...), so that the stream parser
    builds one in a single C call; it behaves as a frozen value class otherwise: fields
    by name, equal only to a message of the same class with the same values, no ordering.
    """

    __slots__ = ()
    SPEC: ClassVar[MessageSpec]
    #: the product line the message belongs to (spec/lines.json); the generated classes are MC's
    LINE: ClassVar[str] = "mc"

    if TYPE_CHECKING:  # the generated classes define the real constructors
        id: int

        def __new__(cls, id: int, *fields: int, **named: int) -> Self: ...  # noqa: A002
    else:
        id = field_getter(0, "the controller ID (255 = broadcast, commands only)")

    def __eq__(self, other: object) -> bool:
        if other.__class__ is self.__class__:
            return tuple.__eq__(self, other)
        # Not NotImplemented for a tuple: Python would then ask tuple.__eq__, which compares items.
        return False if isinstance(other, tuple) else NotImplemented

    def __ne__(self, other: object) -> bool:
        if other.__class__ is self.__class__:
            return tuple.__ne__(self, other)
        return True if isinstance(other, tuple) else NotImplemented

    __hash__ = tuple.__hash__

    # Messages have no order (a frozen value class, not a sequence of numbers).
    def __lt__(self, other: object) -> bool:
        return NotImplemented

    __le__ = __gt__ = __ge__ = __lt__

    def __repr__(self) -> str:
        names = ("id", *self.SPEC.field_names)
        return f"{type(self).__name__}({', '.join(f'{n}={v!r}' for n, v in zip(names, self, strict=True))})"

    def __getnewargs__(self) -> tuple[int, ...]:  # copy and pickle call __new__(cls, *values)
        return tuple(self)

    def check(self) -> Self:
        """This message if its ID and every field are in range; else FieldRangeError/FieldTypeError.

        Decoding takes values as they are (a controller may send anything); check on request.
        """
        spec = self.SPEC
        check_id(spec, self.id)
        for f, value in zip(spec.fields, self[1:], strict=True):
            check_value(spec, f, value)
        return self

    def encode(self) -> bytes:
        """The whole frame; raises EncodeError if the ID or a field is out of range."""
        spec = self.SPEC
        check_id(spec, self.id)
        values = [check_value(spec, f, v) for f, v in zip(spec.fields, self[1:], strict=True)]
        return build_frame(self.id, spec.mode, spec.layout.pack(*values))

    @property
    def name(self) -> str:
        return self.SPEC.name

    @property
    def is_broadcast(self) -> bool:
        return self.id == 0xFF

    def fields(self) -> dict[str, int]:
        """Field values as raw wire integers, in wire order."""
        return dict(zip(self.SPEC.field_names, self[1:], strict=True))

    def to_dict(self) -> dict[str, Any]:
        """The conformance form: {"id": .., "message": .., <fields>}."""
        return {"id": self.id, "message": self.SPEC.name, **self.fields()}

    def physical(self) -> dict[str, float | int | str]:
        """Field values in physical units (degrees, RPM, A, s, us, ratio) or value names."""
        out: dict[str, float | int | str] = {}
        for f, raw in zip(self.SPEC.fields, self[1:], strict=True):
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
