"""Frame layout: header, ID, size, checksum, mode, data (see docs/protocol.md)."""

from __future__ import annotations

from ._tables import HEADER

# Byte offsets inside a frame.
ID_OFFSET, SIZE_OFFSET, CHECKSUM_OFFSET, MODE_OFFSET, DATA_OFFSET = 2, 3, 4, 5, 6


def checksum(frame_id: int, size: int, mode: int, data: bytes | bytearray | memoryview) -> int:
    """~(ID + size + mode + every data byte) & 0xFF: every byte but header and checksum."""
    return ~(frame_id + size + mode + sum(data)) & 0xFF


def build_frame(frame_id: int, mode: int, data: bytes) -> bytes:
    size = len(data) + 2
    return HEADER + bytes((frame_id, size, checksum(frame_id, size, mode, data), mode)) + data
