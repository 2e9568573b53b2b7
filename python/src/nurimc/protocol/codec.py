"""Encode and decode whole frames (sans-I/O: bytes in, typed messages out)."""

from __future__ import annotations

from typing import Any

from .decoding import decode_with
from .errors import MissingFieldError, UnknownFieldError, UnknownMessageError
from .frame import DATA_OFFSET, ID_OFFSET, build_frame
from .message import Command, Message, Request
from .messages import BY_MODE, MESSAGES


def message_class(name: str) -> type[Message]:
    try:
        return MESSAGES[name]
    except KeyError:
        raise UnknownMessageError(f"unknown message {name!r}; known messages: {', '.join(MESSAGES)}", name) from None


def make(name: str, id: int, **fields: Any) -> Message:  # noqa: A002 - `id` is the protocol's word
    """Build a message by its canonical name; missing or unknown fields are errors."""
    cls = message_class(name)
    wanted = cls.SPEC.field_names
    for field in wanted:
        if field not in fields:
            raise MissingFieldError(
                f"{name} needs the field {field!r} (fields: {', '.join(wanted) or 'none'})", name, field
            )
    for field in fields:
        if field not in wanted:
            raise UnknownFieldError(
                f"{name} has no field {field!r} (fields: {', '.join(wanted) or 'none'})", name, field
            )
    return cls(id, **fields)


def make_request(name: str, id: int) -> Request:  # noqa: A002
    """A feedback request by name (TypeError if `name` is not a request)."""
    message = make(name, id)
    if not isinstance(message, Request):
        raise TypeError(f"{name} is not a feedback request")
    return message


def make_command(name: str, id: int, **fields: Any) -> Command:  # noqa: A002
    """A command by name (TypeError if `name` is not a command)."""
    message = make(name, id, **fields)
    if not isinstance(message, Command):
        raise TypeError(f"{name} is not a command")
    return message


def encode(message: Message) -> bytes:
    return message.encode()


def decode(frame: bytes | bytearray | memoryview, line: str = "mc") -> Message:
    """Exactly one whole frame -> its message. Out-of-range field values decode as they are.

    Raises DecodeError whose kind is the first failing check, in this order:
    header, truncated, trailing, checksum, unknown_mode, size. `line` names the product
    line whose mode table reads the frame (spec/lines.json; UnknownLineError if none).
    """
    if line != "mc":
        from .lines import line as line_named

        return line_named(line).decode(frame)
    return decode_with(bytes(frame), BY_MODE)


def decode_valid(cls: type[Message], raw: bytes | bytearray, start: int) -> Message:
    """Decode a frame already checked by the stream parser (no checks repeated)."""
    return cls(raw[start + ID_OFFSET], *cls.SPEC.layout.unpack_from(raw, start + DATA_OFFSET))


def wire_bytes(frame: Message) -> bytes:
    """The frame's bytes exactly as they were on the wire, whatever its values.

    Not `frame.encode()`: that checks the frame as something to send, and refuses what the
    codec would not send but the bus carried (discovery's broadcast ping, a controller's
    out-of-range value). The parser took the frame by its size, mode and checksum, and its
    fields unpack from and pack to the same bytes, so this rebuilds the bytes seen.
    """
    spec = frame.SPEC
    return build_frame(frame.id, spec.mode, spec.layout.pack(*frame[1:]))
