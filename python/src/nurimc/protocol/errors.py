"""Errors of the protocol layer. Each says what was wrong and what to do."""

from __future__ import annotations


class NurimcError(Exception):
    """The root of every error nurimc raises on purpose (re-exported as nurimc.NurimcError).

    It lives here, in the protocol package, because that package imports nothing else of
    nurimc (nor any third-party package) and every other layer imports it."""


class ProtocolError(NurimcError, ValueError):
    """Base class of every error raised by nurimc.protocol (bad bytes, a value the wire cannot carry)."""


class EncodeError(ProtocolError):
    """A message could not be encoded. `kind` is the conformance error name."""

    kind = "encode"

    def __init__(self, text: str, message: str | None = None, field: str | None = None) -> None:
        super().__init__(text)
        self.message = message
        self.field = field


class UnknownMessageError(EncodeError):
    kind = "unknown_message"


class MissingFieldError(EncodeError):
    kind = "missing_field"


class UnknownFieldError(EncodeError):
    kind = "unknown_field"


class FieldTypeError(EncodeError):
    kind = "type"


class FieldRangeError(EncodeError):
    """A field value outside its allowed range; names message, field, value, range and unit."""

    kind = "range"

    def __init__(self, message: str, field: str, value: object, allowed: str) -> None:
        super().__init__(f"{message}.{field} = {value!r} is out of range; allowed: {allowed}", message, field)
        self.value = value
        self.allowed = allowed


class DecodeError(ProtocolError):
    """Bytes that are not one valid frame. `kind` is one of DECODE_ERROR_KINDS."""

    def __init__(self, kind: str, text: str) -> None:
        super().__init__(text)
        self.kind = kind


# The order in which decode checks a frame; the first failing check names the error.
DECODE_ERROR_KINDS = ("header", "truncated", "trailing", "checksum", "unknown_mode", "size")


class UnknownLineError(ProtocolError):
    """A product line name that spec/lines.json does not have."""

    kind = "unknown_line"


class WrongLineError(EncodeError):
    """A message of one product line sent to, or built for, a controller of another."""

    kind = "wrong_line"
