"""The stream parser: bytes in any chunking -> whole frames, plus counted diagnostics.

The rule (conformance/README.md, the same in every language): scanning from the
first byte, where a whole valid frame starts, take it; otherwise drop one byte and
look again from the next. So a false header costs one byte and a real frame behind
it is never lost. Candidates are rejected as early as their bytes allow (a size byte
no message has, an unknown mode), so the buffer never holds more than one frame's
worth of bytes between calls and a false header never holds later frames hostage.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from ._tables import HEADER, MAX_SIZE
from .codec import decode_valid
from .frame import CHECKSUM_OFFSET, MODE_OFFSET, SIZE_OFFSET
from .message import Message
from .messages import BY_MODE

_HEADER_BYTE = HEADER[0]


@dataclass
class ParserStats:
    """What the parser has seen since it was made (or reset)."""

    frames: int = 0
    dropped_bytes: int = 0  # every byte not part of a returned frame
    bad_checksum: int = 0
    unknown_mode: int = 0
    bad_size: int = 0

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


class StreamParser:
    """Feed bytes, get messages. Never raises on garbage; memory stays bounded."""

    def __init__(self) -> None:
        self._buf = bytearray()
        self.stats = ParserStats()

    @property
    def pending(self) -> int:
        """Bytes held back because they may begin a frame."""
        return len(self._buf)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Message]:
        """Add bytes; return every frame they complete, in order."""
        self._buf += data
        return self._scan(final=False)

    def finish(self) -> list[Message]:
        """End of stream (or the line went quiet): resolve held bytes; a partial frame is dropped."""
        return self._scan(final=True)

    def clear(self) -> None:
        """Forget held bytes (counted as dropped), e.g. before a new request."""
        self.stats.dropped_bytes += len(self._buf)
        self._buf.clear()

    def _scan(self, final: bool) -> list[Message]:
        buf, stats, out = self._buf, self.stats, []
        n, pos = len(buf), 0
        while pos < n:
            start = buf.find(HEADER, pos)
            if start < 0:
                keep = 1 if not final and buf[n - 1] == _HEADER_BYTE else 0
                stats.dropped_bytes += n - keep - pos
                pos = n - keep
                break
            stats.dropped_bytes += start - pos
            pos = start
            if self._reject_early(buf, pos, n):
                pos += 1
                continue
            if n - pos >= 6:
                cls = BY_MODE[buf[pos + MODE_OFFSET]]
                end = pos + buf[pos + SIZE_OFFSET] + 4
                if end <= n:
                    expected = ~(sum(buf[pos + 2 : pos + CHECKSUM_OFFSET]) + sum(buf[pos + MODE_OFFSET : end])) & 0xFF
                    if buf[pos + CHECKSUM_OFFSET] == expected:
                        out.append(decode_valid(cls, buf, pos))
                        stats.frames += 1
                        pos = end
                    else:
                        stats.bad_checksum += 1
                        stats.dropped_bytes += 1
                        pos += 1
                    continue
            if not final:
                break  # an incomplete candidate: wait for more bytes
            stats.dropped_bytes += 1
            pos += 1
        del buf[:pos]
        return out

    def _reject_early(self, buf: bytearray, pos: int, n: int) -> bool:
        """True (and counted) if the candidate at pos is no frame, judging by the bytes present."""
        if n - pos < 4:
            return False
        size = buf[pos + SIZE_OFFSET]
        if size < 2 or size > MAX_SIZE:
            self.stats.bad_size += 1
        elif n - pos < 6:
            return False
        else:
            cls = BY_MODE.get(buf[pos + MODE_OFFSET])
            if cls is not None and cls.SPEC.size == size:
                return False
            if cls is None:
                self.stats.unknown_mode += 1
            else:
                self.stats.bad_size += 1
        self.stats.dropped_bytes += 1
        return True
