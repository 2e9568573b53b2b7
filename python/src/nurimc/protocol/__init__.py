"""The MC-RS485 protocol, sans-I/O: typed messages, frame codec, stream parser, units.

>>> from nurimc.protocol import PositionSpeed, decode
>>> frame = PositionSpeed(id=0, direction=0, position=18000, speed=1000).encode()
>>> frame.hex(" ")
'ff fe 00 07 76 01 00 46 50 03 e8'
>>> decode(frame)
PositionSpeed(id=0, direction=0, position=18000, speed=1000)
"""

from . import messages as _messages
from ._tables import BAUD_RATES, BROADCAST_ID, DEVICE_DEFAULTS, HEADER, MAX_DEVICE_ID, PRODUCTS, PROTOCOL, SPECS
from .codec import decode, encode, make, make_command, make_request, message_class, wire_bytes
from .errors import (
    DecodeError,
    EncodeError,
    FieldRangeError,
    FieldTypeError,
    MissingFieldError,
    NurimcError,
    ProtocolError,
    UnknownFieldError,
    UnknownLineError,
    UnknownMessageError,
    WrongLineError,
)
from .frame import build_frame, checksum
from .lines import ALL_LINES, Line, line, line_of, product_line
from .message import Answer, Command, Message, Request
from .messages import *  # noqa: F403 - one class per message, generated
from .messages import BY_MODE, MESSAGES
from .parser import ParserStats, StreamParser
from .schema import FieldSpec, Kind, LineSpec, MessageSpec, ProductSpec


def baud_index(rate: int) -> int:
    """The baud-rate table index of `rate`, or ValueError listing the 18 rates."""
    try:
        return BAUD_RATES.index(rate)
    except ValueError:
        rates = ", ".join(str(r) for r in BAUD_RATES)
        raise ValueError(f"{rate} bps is not a rate these controllers support; use one of {rates}") from None


def answer_class(request: type[Message]) -> type[Message]:
    """The answer class of a request class (answer mode = request mode + 0x30)."""
    name = request.SPEC.answer
    if name is None:
        raise ValueError(f"{request.SPEC.name} is not a request; commands are never answered")
    if request.LINE != "mc":  # another product line: its own answer class (spec/lines.json)
        return line_of(request).answer_class(request)
    return MESSAGES[name]


__all__ = [
    "ALL_LINES",
    "Answer",
    "BAUD_RATES",
    "BROADCAST_ID",
    "BY_MODE",
    "Command",
    "DEVICE_DEFAULTS",
    "DecodeError",
    "EncodeError",
    "FieldRangeError",
    "FieldSpec",
    "FieldTypeError",
    "HEADER",
    "Kind",
    "Line",
    "LineSpec",
    "MAX_DEVICE_ID",
    "MESSAGES",
    "Message",
    "MessageSpec",
    "MissingFieldError",
    "NurimcError",
    "PRODUCTS",
    "PROTOCOL",
    "ParserStats",
    "ProductSpec",
    "ProtocolError",
    "Request",
    "SPECS",
    "StreamParser",
    "UnknownFieldError",
    "UnknownLineError",
    "UnknownMessageError",
    "WrongLineError",
    "answer_class",
    "baud_index",
    "build_frame",
    "checksum",
    "line",
    "line_of",
    "product_line",
    "decode",
    "encode",
    "make",
    "make_command",
    "make_request",
    "message_class",
    *_messages.__all__,
    "wire_bytes",
]
