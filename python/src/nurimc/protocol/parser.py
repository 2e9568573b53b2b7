"""The stream parser: bytes in any chunking -> whole frames, plus counted diagnostics.

The rule (conformance/README.md, the same in every language): scanning from the
first byte, where a whole valid frame starts, take it; otherwise drop one byte and
look again from the next. So a false header costs one byte and a real frame behind
it is never lost. Candidates are rejected as early as their bytes allow (a size byte
no message has, an unknown mode), so the buffer never holds more than one frame's
worth of bytes between calls and a false header never holds later frames hostage.

Speed (docs/performance.md): `feed` takes every whole valid frame on a fast path of a
few operations, with no copy of the chunk; everything else (noise, a false header, a
frame cut by the chunk boundary) goes to `_candidate`, which states the rule in full.
A message is built by one struct unpack (ID and fields together) and one tuple
construction. Counters are added up once per call, not per frame.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any
from zlib import adler32 as _adler32

from ._tables import HEADER, MAX_SIZE
from .frame import DATA_OFFSET, ID_OFFSET, MODE_OFFSET, SIZE_OFFSET
from .message import Message
from .messages import BY_MODE

_HEADER_BYTE = HEADER[0]
_NEW = tuple.__new__


_Table = list[tuple[int, int, type[Message], Any] | None]


def _mode_table(by_mode: Mapping[int, type[Message]]) -> _Table:
    """Indexed by mode byte: (size byte, frame length, class, unpack of ID + fields) or None."""
    table: _Table = [None] * 256
    for mode, cls in by_mode.items():
        skip = DATA_OFFSET - ID_OFFSET - 1  # size, checksum and mode lie between the ID and the data
        layout = struct.Struct(f">B{skip}x{cls.SPEC.layout.format.lstrip('>')}")
        table[mode] = (cls.SPEC.size, cls.SPEC.size + 4, cls, layout.unpack_from)
    return table


_BY_MODE = _mode_table(BY_MODE)
_LINE_TABLES: dict[str, _Table] = {"mc": _BY_MODE}


def _line_table(key: str) -> _Table:
    """The mode table of a product line (spec/lines.json), made on first use."""
    table = _LINE_TABLES.get(key)
    if table is None:
        from .lines import line  # lines imports the parser's siblings only; here to keep MC's import light

        table = _LINE_TABLES[key] = _mode_table(line(key).by_mode)
    return table


@dataclass
class ParserStats:
    """What the parser has seen since it was made (or reset)."""

    frames: int = 0
    dropped_bytes: int = 0  # every byte not part of a returned frame
    bad_checksum: int = 0
    unknown_mode: int = 0
    bad_size: int = 0
    out_of_range: int = 0  # valid frames held back by check_ranges=True (their bytes count as dropped)

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def answer_unpacker(cls: type[Message], line: str = "mc") -> Any:
    """`unpack(frame, 2)`: the ID and fields of a whole `cls` frame, as `feed` reads them (the
    frame's checks are the caller's), if `line`'s table reads `cls`'s mode as `cls`; else None.
    For a caller that knows which answer comes (drivers/fastpath.py)."""
    entry = _line_table(line)[cls.SPEC.mode]
    return entry[3] if entry is not None and entry[2] is cls else None


class StreamParser:
    """Feed bytes, get messages. Never raises on garbage; memory stays bounded.

    Field values come as they are on the wire; with check_ranges=True a frame whose ID or
    a field is out of range is not returned but counted (stats.out_of_range). `line` names
    the product line whose mode table reads the frames (spec/lines.json; default MC).
    """

    def __init__(self, *, check_ranges: bool = False, line: str = "mc") -> None:
        self._by_mode = _line_table(line)
        self.line = line
        self._held = b""  # the start of a frame cut by the end of the last chunk
        self.check_ranges = check_ranges
        self.stats = ParserStats()
        if check_ranges:
            self.feed = self._feed_in_range  # type: ignore[method-assign]

    @property
    def pending(self) -> int:
        """Bytes held back because they may begin a frame."""
        return len(self._held)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Message]:
        """Add bytes; return every frame they complete, in order."""
        held = self._held
        buf: bytes
        if held:
            buf = held + data
        elif type(data) is bytes:
            buf = data  # no copy: only a cut frame at the end is kept
        else:
            buf = bytes(data)
        n = len(buf)
        out: list[Message] = []
        pos = dropped = 0
        by_mode = self._by_mode
        while pos < n:
            if buf[pos] == 0xFF and pos + 1 < n and buf[pos + 1] == 0xFE:
                start = pos  # the usual case: the next frame follows the last one (cheaper than find)
            else:
                start = buf.find(b"\xff\xfe", pos)
                if start < 0:  # no header: drop all but a last FF, which may begin one
                    keep = 1 if buf[n - 1] == _HEADER_BYTE else 0
                    dropped += n - keep - pos
                    pos = n - keep
                    break
                dropped += start - pos
            if start + 6 > n:
                if start + 4 > n or 2 <= buf[start + 3] <= MAX_SIZE:
                    pos = start  # too short to judge yet
                    break
            else:
                entry = by_mode[buf[start + 5]]
                if entry is not None and entry[0] == buf[start + 3]:
                    end = start + entry[1]
                    if end > n:
                        pos = start  # a frame cut by the end of the chunk: wait for the rest
                        break
                    # The checksum is ~(ID + size + mode + data), so the bytes from the ID on sum to
                    # xxFF. adler32's low 16 bits are 1 + that sum (it stays far below 65521): one C
                    # call where sum() over a slice costs twice as much.
                    if not _adler32(buf[start + 2 : end]) & 0xFF:
                        out.append(_NEW(entry[2], entry[3](buf, start + 2)))
                        pos = end
                        continue
            message, pos = self._candidate(buf, start, final=False)
            if pos < 0:  # an incomplete candidate: wait for more bytes
                pos = start
                break
            if message is not None:
                out.append(message)
        self._held = buf[pos:]
        if dropped:
            self.stats.dropped_bytes += dropped
        self.stats.frames += len(out)
        return out

    def _feed_in_range(self, data: bytes | bytearray | memoryview) -> list[Message]:
        return self._in_range(StreamParser.feed(self, data))

    def finish(self) -> list[Message]:
        """End of stream (or the line went quiet): resolve held bytes; a partial frame is dropped."""
        data, self._held = self._held, b""
        out: list[Message] = []
        pos = 0
        while pos < len(data):
            start = data.find(HEADER, pos)
            if start < 0:
                start = len(data)
            self.stats.dropped_bytes += start - pos
            if start == len(data):
                break
            message, pos = self._candidate(data, start, final=True)
            if message is not None:
                out.append(message)
        self.stats.frames += len(out)
        return self._in_range(out) if self.check_ranges else out

    def clear(self) -> None:
        """Forget held bytes (counted as dropped), e.g. before a new request."""
        self.stats.dropped_bytes += len(self._held)
        self._held = b""

    def _candidate(self, data: bytes, start: int, final: bool) -> tuple[Message | None, int]:
        """Resolve the header at `start`: (the message or None, where to go on), or (None, -1): wait.

        The whole rule, with its counters; `feed` only comes here off its fast path.
        """
        stats, n = self.stats, len(data)
        if n - start >= 4:
            size = data[start + SIZE_OFFSET]
            entry = self._by_mode[data[start + MODE_OFFSET]] if n - start >= 6 else None
            if size < 2 or size > MAX_SIZE:
                stats.bad_size += 1
            elif n - start < 6:
                return self._wait_or_drop(start, final)  # the mode is yet to come
            elif entry is None:
                stats.unknown_mode += 1
            elif entry[0] != size:
                stats.bad_size += 1
            elif start + entry[1] > n:
                return self._wait_or_drop(start, final)  # an incomplete frame
            elif sum(data[start + ID_OFFSET : start + entry[1]]) & 0xFF == 0xFF:
                return _NEW(entry[2], entry[3](data, start + ID_OFFSET)), start + entry[1]
            else:
                stats.bad_checksum += 1
            stats.dropped_bytes += 1  # rejected: one byte goes, the search goes on from the next
            return None, start + 1
        return self._wait_or_drop(start, final)

    def _wait_or_drop(self, start: int, final: bool) -> tuple[None, int]:
        """A candidate too short to judge: wait for more, or at the end of the stream drop its first byte."""
        if not final:
            return None, -1
        self.stats.dropped_bytes += 1
        return None, start + 1

    def _in_range(self, messages: list[Message]) -> list[Message]:
        kept = []
        for message in messages:
            try:
                kept.append(message.check())
            except ValueError:
                self.stats.out_of_range += 1
                self.stats.frames -= 1
                self.stats.dropped_bytes += message.SPEC.size + 4
        return kept
