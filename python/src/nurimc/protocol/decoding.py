"""One whole frame -> its message, read with a given mode table (MC's, or another product
line's): the checks every line shares, in one order (nurimc.protocol.codec.decode)."""

from __future__ import annotations

from collections.abc import Mapping

from ._tables import HEADER, MIN_FRAME_LENGTH
from .errors import DecodeError
from .frame import CHECKSUM_OFFSET, DATA_OFFSET, ID_OFFSET, MODE_OFFSET, SIZE_OFFSET
from .message import Message


def decode_with(raw: bytes, by_mode: Mapping[int, type[Message]]) -> Message:
    """decode() with a given mode table (a product line's); DecodeError names the first failing check."""
    if raw[:2] != HEADER[: len(raw[:2])]:
        raise DecodeError("header", f"frame must start with FF FE, got {raw[:2].hex(' ').upper()}")
    if len(raw) < MIN_FRAME_LENGTH or len(raw) < raw[SIZE_OFFSET] + 4:
        raise DecodeError("truncated", f"frame is truncated ({len(raw)} bytes)")
    size = raw[SIZE_OFFSET]
    if len(raw) > size + 4:
        raise DecodeError("trailing", f"{len(raw) - size - 4} bytes after the frame (size byte says {size})")
    expected = ~sum(raw[ID_OFFSET:CHECKSUM_OFFSET] + raw[MODE_OFFSET:]) & 0xFF
    if raw[CHECKSUM_OFFSET] != expected:
        raise DecodeError("checksum", f"checksum is {raw[CHECKSUM_OFFSET]:02X}, the bytes give {expected:02X}")
    cls = by_mode.get(raw[MODE_OFFSET])
    if cls is None:
        raise DecodeError("unknown_mode", f"unknown mode {raw[MODE_OFFSET]:02X}")
    if size != cls.SPEC.size:
        raise DecodeError(
            "size", f"{cls.SPEC.name} (mode {cls.SPEC.mode:02X}) has size {cls.SPEC.size}, frame says {size}"
        )
    return cls(raw[ID_OFFSET], *cls.SPEC.layout.unpack_from(raw, DATA_OFFSET))
