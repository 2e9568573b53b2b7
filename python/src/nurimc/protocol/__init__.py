"""The MC-RS485 protocol, sans-I/O: typed messages, frame codec, stream parser, units.

>>> from nurimc.protocol import PositionSpeed, decode
>>> frame = PositionSpeed(id=0, direction=0, position=18000, speed=1000).encode()
>>> frame.hex(" ")
'ff fe 00 07 76 01 00 46 50 03 e8'
>>> decode(frame)
PositionSpeed(id=0, direction=0, position=18000, speed=1000)
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # what the names below are; at run time each module loads when first used
    from ._tables import (
        BAUD_RATES as BAUD_RATES,
    )
    from ._tables import (
        BROADCAST_ID as BROADCAST_ID,
    )
    from ._tables import (
        DEVICE_DEFAULTS as DEVICE_DEFAULTS,
    )
    from ._tables import (
        HEADER as HEADER,
    )
    from ._tables import (
        MAX_DEVICE_ID as MAX_DEVICE_ID,
    )
    from ._tables import (
        PRODUCTS as PRODUCTS,
    )
    from ._tables import (
        PROTOCOL as PROTOCOL,
    )
    from ._tables import (
        SPECS as SPECS,
    )
    from .codec import (
        decode as decode,
    )
    from .codec import (
        encode as encode,
    )
    from .codec import (
        make as make,
    )
    from .codec import (
        make_command as make_command,
    )
    from .codec import (
        make_request as make_request,
    )
    from .codec import (
        message_class as message_class,
    )
    from .codec import (
        wire_bytes as wire_bytes,
    )
    from .errors import (
        DecodeError as DecodeError,
    )
    from .errors import (
        EncodeError as EncodeError,
    )
    from .errors import (
        FieldRangeError as FieldRangeError,
    )
    from .errors import (
        FieldTypeError as FieldTypeError,
    )
    from .errors import (
        MissingFieldError as MissingFieldError,
    )
    from .errors import (
        NurimcError as NurimcError,
    )
    from .errors import (
        ProtocolError as ProtocolError,
    )
    from .errors import (
        UnknownFieldError as UnknownFieldError,
    )
    from .errors import (
        UnknownLineError as UnknownLineError,
    )
    from .errors import (
        UnknownMessageError as UnknownMessageError,
    )
    from .errors import (
        WrongLineError as WrongLineError,
    )
    from .frame import (
        build_frame as build_frame,
    )
    from .frame import (
        checksum as checksum,
    )
    from .lines import (
        ALL_LINES as ALL_LINES,
    )
    from .lines import (
        Line as Line,
    )
    from .lines import (
        line as line,
    )
    from .lines import (
        line_of as line_of,
    )
    from .lines import (
        product_line as product_line,
    )
    from .message import (
        Answer as Answer,
    )
    from .message import (
        Command as Command,
    )
    from .message import (
        Message as Message,
    )
    from .message import (
        Request as Request,
    )
    from .messages import *  # noqa: F403 - one class per message, generated
    from .messages import (
        BY_MODE as BY_MODE,
    )
    from .messages import (
        MESSAGES as MESSAGES,
    )
    from .parser import (
        ParserStats as ParserStats,
    )
    from .parser import (
        StreamParser as StreamParser,
    )
    from .schema import (
        FieldSpec as FieldSpec,
    )
    from .schema import (
        Kind as Kind,
    )
    from .schema import (
        LineSpec as LineSpec,
    )
    from .schema import (
        MessageSpec as MessageSpec,
    )
    from .schema import (
        ProductSpec as ProductSpec,
    )

#: name -> the module that defines it. The package loads a module when one of its names is first
#: used, so `nurimc --help` (which needs the rate and product tables) does not build every message
#: class (docs/performance.md, start-up); `from nurimc.protocol import X` works as before.
_SOURCES = {
    "BAUD_RATES": "._tables",
    "BROADCAST_ID": "._tables",
    "DEVICE_DEFAULTS": "._tables",
    "HEADER": "._tables",
    "MAX_DEVICE_ID": "._tables",
    "PRODUCTS": "._tables",
    "PROTOCOL": "._tables",
    "SPECS": "._tables",
    "decode": ".codec",
    "encode": ".codec",
    "make": ".codec",
    "make_command": ".codec",
    "make_request": ".codec",
    "message_class": ".codec",
    "wire_bytes": ".codec",
    "DecodeError": ".errors",
    "EncodeError": ".errors",
    "FieldRangeError": ".errors",
    "FieldTypeError": ".errors",
    "MissingFieldError": ".errors",
    "NurimcError": ".errors",
    "ProtocolError": ".errors",
    "UnknownFieldError": ".errors",
    "UnknownLineError": ".errors",
    "UnknownMessageError": ".errors",
    "WrongLineError": ".errors",
    "build_frame": ".frame",
    "checksum": ".frame",
    "ALL_LINES": ".lines",
    "Line": ".lines",
    "line": ".lines",
    "line_of": ".lines",
    "product_line": ".lines",
    "Answer": ".message",
    "Command": ".message",
    "Message": ".message",
    "Request": ".message",
    "BY_MODE": ".messages",
    "MESSAGES": ".messages",
    "ParserStats": ".parser",
    "StreamParser": ".parser",
    "FieldSpec": ".schema",
    "Kind": ".schema",
    "LineSpec": ".schema",
    "MessageSpec": ".schema",
    "ProductSpec": ".schema",
}


def __getattr__(name: str) -> Any:
    if name == "__all__":
        return _all()
    source = _SOURCES.get(name)
    if source is not None:
        value = getattr(importlib.import_module(source, __name__), name)
    else:
        messages = importlib.import_module(".messages", __name__)
        if name not in messages.__all__:  # one class per message, generated
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        value = getattr(messages, name)
    globals()[name] = value  # found directly next time
    return value


def baud_index(rate: int) -> int:
    """The baud-rate table index of `rate`, or ValueError listing the 18 rates."""
    from ._tables import BAUD_RATES

    try:
        return BAUD_RATES.index(rate)
    except ValueError:
        rates = ", ".join(str(r) for r in BAUD_RATES)
        raise ValueError(f"{rate} bps is not a rate these controllers support; use one of {rates}") from None


def answer_class(request: type[Message]) -> type[Message]:
    """The answer class of a request class (answer mode = request mode + 0x30)."""
    from .lines import line_of
    from .messages import MESSAGES

    name = request.SPEC.answer
    if name is None:
        raise ValueError(f"{request.SPEC.name} is not a request; commands are never answered")
    if request.LINE != "mc":  # another product line: its own answer class (spec/lines.json)
        return line_of(request).answer_class(request)
    return MESSAGES[name]


def _all() -> list[str]:
    """Every public name (`from nurimc.protocol import *`), the message classes among them."""
    messages = importlib.import_module(".messages", __name__)
    return [
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
        *messages.__all__,
        "wire_bytes",
    ]
