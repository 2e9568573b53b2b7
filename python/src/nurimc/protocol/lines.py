"""Product lines: the same frame, a different message table per line (spec/lines.json).

MC's messages are the generated classes of `messages.py` (their LINE is "mc"). Every other
line gets its own classes, made here once from the generated `_lines.py`, so that a message
always knows its line: an RSA `set_ratio` (mode 09) is a different class from MC's
`SetRatio` (mode 0B), and a motor of one line refuses another line's messages
(docs/protocol.md, Product lines).

>>> rsa = line("rsa")
>>> rsa.make("set_ratio", 0, ratio=100).encode().hex(" ")
'ff fe 00 04 8e 09 00 64'
>>> rsa.decode(bytes.fromhex("fffe0004e809000a"))
RsaSetRatio(id=0, ratio=10)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ._lines import LINES, PRODUCT_LINES
from .decoding import decode_with
from .errors import MissingFieldError, UnknownFieldError, UnknownLineError, UnknownMessageError, WrongLineError
from .message import Answer, Command, Message, Request, field_getter
from .messages import BY_MODE, MESSAGES
from .schema import Kind, LineSpec, MessageSpec

_BASES: dict[Kind, type[Message]] = {Kind.COMMAND: Command, Kind.REQUEST: Request, Kind.ANSWER: Answer}


def _camel(text: str) -> str:
    return "".join(part.capitalize() for part in text.replace("-", "_").split("_"))


def _message_class(line: str, spec: MessageSpec) -> type[Message]:
    """A message class of a line other than MC: the same machinery as the generated ones."""
    names = ("id", *spec.field_names)

    def __new__(cls: type[Message], *args: int, **named: int) -> Message:
        if len(args) > len(names):
            raise TypeError(f"{cls.__name__} takes {len(names)} values ({', '.join(names)}), got {len(args)}")
        values = dict(zip(names, args, strict=False))
        for key, value in named.items():
            if key not in names or key in values:
                raise TypeError(f"{cls.__name__}: unexpected or repeated field {key!r} (fields: {', '.join(names)})")
            values[key] = value
        missing = [n for n in names if n not in values]
        if missing:
            raise TypeError(f"{cls.__name__} needs {', '.join(missing)}")
        return tuple.__new__(cls, tuple(values[n] for n in names))

    namespace: dict[str, Any] = {
        "__slots__": (),
        "__doc__": f"{spec.title} (line {line}, mode 0x{spec.mode:02X}, size {spec.size}).",
        "__module__": __name__,
        "SPEC": spec,
        "LINE": line,
        "__match_args__": names,
        "__new__": __new__,
    }
    for index, f in enumerate(spec.fields, start=1):
        namespace[f.name] = field_getter(index, f.name)
    cls = type(_camel(line) + _camel(spec.name), (_BASES[spec.kind],), namespace)
    globals()[cls.__name__] = cls  # importable by name, so that messages pickle
    return cls


@dataclass(frozen=True)
class Line:
    """One product line: its facts and its message classes by name and by mode byte."""

    spec: LineSpec
    classes: Mapping[str, type[Message]]
    by_mode: Mapping[int, type[Message]] = field(repr=False)

    @property
    def key(self) -> str:
        return self.spec.key

    @property
    def title(self) -> str:
        return self.spec.title

    def has(self, name: str) -> bool:
        return name in self.classes

    def message_class(self, name: str) -> type[Message]:
        """The line's class of a message by canonical name; an error naming the lines that have it."""
        try:
            return self.classes[name]
        except KeyError:
            others = [key for key, other in _LINES.items() if name in other.classes]
            where = f" (it is a message of {', '.join(others)})" if others else ""
            raise UnknownMessageError(
                f"{self.title} has no message {name!r}{where}; {self.title} messages: {', '.join(self.classes)}",
                name,
            ) from None

    def make(self, name: str, id: int, **fields: Any) -> Message:  # noqa: A002 - the protocol's word
        """Build a message of this line by name; missing or unknown fields are errors."""
        cls = self.message_class(name)
        wanted = cls.SPEC.field_names
        for f in wanted:
            if f not in fields:
                raise MissingFieldError(
                    f"{name} needs the field {f!r} (fields: {', '.join(wanted) or 'none'})", name, f
                )
        for f in fields:
            if f not in wanted:
                raise UnknownFieldError(f"{name} has no field {f!r} (fields: {', '.join(wanted) or 'none'})", name, f)
        return cls(id, **fields)

    def check(self, message: Message) -> Message:
        """The message if it belongs to this line; else WrongLineError (never send it)."""
        if self.key != message.LINE:
            raise WrongLineError(
                f"{message.name} of the {_LINES[message.LINE].title} line cannot go to a controller of the "
                f"{self.title} line: "
                f"mode {message.SPEC.mode:02X} means something else there"
                + (
                    f"; use {self.title}'s own {message.name} (mode {self.classes[message.name].SPEC.mode:02X})"
                    if message.name in self.classes
                    else f"; {self.title} has no {message.name}"
                ),
                message.name,
            )
        return message

    def means_the_same(self, message: Message) -> bool:
        """Is the message's frame this line's message of the same name (same mode and size)?
        Ping, firmware and the shared motion codes are; RSA's set_control (0A) is not MC's (0C)."""
        if self.key == message.LINE:
            return True
        own = self.classes.get(message.name)
        return own is not None and own.SPEC.mode == message.SPEC.mode and own.SPEC.size == message.SPEC.size

    def decode(self, frame: bytes | bytearray | memoryview) -> Message:
        """Exactly one whole frame -> this line's message (the checks and order of codec.decode)."""
        return decode_with(bytes(frame), self.by_mode)

    def answer_class(self, request: type[Message]) -> type[Message]:
        name = request.SPEC.answer
        if name is None:
            raise ValueError(f"{request.SPEC.name} is not a request; commands are never answered")
        return self.classes[name]


def _build() -> dict[str, Line]:
    out = {"mc": Line(LINES["mc"], MESSAGES, BY_MODE)}
    for key, spec in LINES.items():
        if key == "mc":
            continue
        classes = {m.name: _message_class(key, m) for m in spec.messages}
        out[key] = Line(spec, classes, {cls.SPEC.mode: cls for cls in classes.values()})
    return out


_LINES = _build()
#: every product line by key: mc, rsa, rsavw, sa, sm, sm-cs, sm-readme
ALL_LINES: Mapping[str, Line] = _LINES


def line(key: str) -> Line:
    """The line named `key`, or UnknownLineError listing the lines."""
    if not isinstance(key, str) or key not in _LINES:
        raise UnknownLineError(f"unknown product line {key!r}; lines: {', '.join(_LINES)}")
    return _LINES[key]


def line_of(message: Message | type[Message]) -> Line:
    """The line a message belongs to."""
    return _LINES[message.LINE]


def product_line(product: str) -> Line:
    """The line a product speaks (mc and blmc-h: MC; spec/lines.json product_lines)."""
    try:
        return _LINES[PRODUCT_LINES[product]]
    except KeyError:
        raise UnknownLineError(f"unknown product {product!r}; products: {', '.join(PRODUCT_LINES)}") from None


#: a simulated controller must speak one table: a simulated "sm" speaks the C# table, the one the
#: vendor's Supporter drives detected SMs with (docs/protocol.md, Product lines)
SIMULATED_LINES: Mapping[str, str] = {**PRODUCT_LINES, "sm": "sm-cs"}
