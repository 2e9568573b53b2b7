"""Frames on a listened-to bus, with what was wrong with the rest (sans-I/O).

`ExplainingParser` follows the stream parser's rule exactly (conformance/README.md: where a
whole valid frame starts, take it; otherwise drop one byte and look again) but also says
why each candidate it dropped was no frame: a bad checksum, a mode the MC / BLMC-H tables
do not have, a size byte that does not fit the mode. The simulator logs these with `-v`;
`Sniffer` adds timestamps and the direction (a request or command goes from the host to a
controller, an answer the other way) for `nurimc sniff`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from . import HEADER, Message
from ._tables import MAX_SIZE
from .codec import decode_valid
from .frame import CHECKSUM_OFFSET, ID_OFFSET, MODE_OFFSET, SIZE_OFFSET
from .lines import line as line_named
from .message import Answer

_FF = HEADER[0]


@dataclass(frozen=True, slots=True)
class SniffedFrame:
    """A whole valid frame."""

    message: Message
    raw: bytes


@dataclass(frozen=True, slots=True)
class Rejected:
    """Bytes that are no frame, and why. `id` is the ID byte of a rejected header candidate."""

    raw: bytes
    reason: str
    id: int | None = None


Event = SniffedFrame | Rejected


class ExplainingParser:
    """Feed bytes, get SniffedFrame and Rejected events in stream order. Never raises; bounded memory."""

    def __init__(self, line: str = "mc") -> None:
        # the product line whose table reads the frames (spec/lines.json)
        self._by_mode = line_named(line).by_mode
        self._what = "an MC / BLMC-H message" if line == "mc" else f"a message of the {line_named(line).title} line"
        self._buf = bytearray()
        self._noise = bytearray()  # skipped bytes not yet reported
        self._covered = 0  # bytes at the buffer's start already reported as part of a candidate

    def feed(self, data: bytes | bytearray | memoryview) -> list[Event]:
        self._buf += data
        return self._scan(final=False)

    def finish(self) -> list[Event]:
        """End of stream (the line went quiet): a partial frame is reported and dropped."""
        return self._scan(final=True)

    def clear(self) -> None:
        self._buf.clear()
        self._noise.clear()
        self._covered = 0

    def _skip(self, byte: int, pos: int) -> None:
        if pos >= self._covered:
            self._noise.append(byte)

    def _flush_noise(self, out: list[Event]) -> None:
        if self._noise:
            out.append(Rejected(bytes(self._noise), f"{len(self._noise)} byte(s) outside any frame"))
            self._noise.clear()

    def _reject(self, out: list[Event], pos: int, length: int, reason: str) -> None:
        self._flush_noise(out)
        raw = bytes(self._buf[pos : pos + length])
        out.append(Rejected(raw, reason, raw[ID_OFFSET] if len(raw) > ID_OFFSET else None))
        self._covered = max(self._covered, pos + length)

    def _scan(self, final: bool) -> list[Event]:
        buf, out = self._buf, list[Event]()
        n, pos = len(buf), 0
        while pos < n:
            start = buf.find(HEADER, pos)
            if start < 0:
                keep = 1 if not final and buf[n - 1] == _FF else 0
                for i in range(pos, n - keep):
                    self._skip(buf[i], i)
                pos = n - keep
                break
            for i in range(pos, start):
                self._skip(buf[i], i)
            pos = start
            verdict = self._candidate(buf, pos, n, final)
            if verdict is None:
                break  # an incomplete candidate: wait for more bytes
            if isinstance(verdict, SniffedFrame):
                self._flush_noise(out)
                out.append(verdict)
                pos += len(verdict.raw)
                continue
            length, reason = verdict
            if pos >= self._covered:
                self._reject(out, pos, length, reason)
            pos += 1  # drop one byte and look again
        self._flush_noise(out)
        del buf[:pos]
        self._covered = max(0, self._covered - pos)
        return out

    def _candidate(self, buf: bytearray, pos: int, n: int, final: bool) -> SniffedFrame | tuple[int, str] | None:
        """The frame at pos, (bytes, reason) if it is none, or None to wait for more bytes."""
        have = n - pos
        if have < 4:
            return (have, "a frame cut short") if final else None
        size = buf[pos + SIZE_OFFSET]
        if size < 2 or size > MAX_SIZE:
            return 4, f"size byte {size} fits no message (2..{MAX_SIZE})"
        if have < 6:
            return (have, "a frame cut short") if final else None
        mode = buf[pos + MODE_OFFSET]
        cls = self._by_mode.get(mode)
        if cls is None:
            return 6, f"unknown mode 0x{mode:02X}: not {self._what}"
        if cls.SPEC.size != size:
            return 6, f"wrong size {size} for {cls.SPEC.name} (mode 0x{mode:02X} has size {cls.SPEC.size})"
        end = pos + size + 4
        if end > n:
            return (have, f"{cls.SPEC.name} cut short") if final else None
        expected = ~(sum(buf[pos + 2 : pos + CHECKSUM_OFFSET]) + sum(buf[pos + MODE_OFFSET : end])) & 0xFF
        if buf[pos + CHECKSUM_OFFSET] != expected:
            got = buf[pos + CHECKSUM_OFFSET]
            return size + 4, f"bad checksum 0x{got:02X} (0x{expected:02X} expected) in a {cls.SPEC.name} frame"
        return SniffedFrame(decode_valid(cls, buf, pos), bytes(buf[pos:end]))


def direction(message: Message) -> str:
    """Who sent it, as far as the message kind tells: answers come from controllers."""
    if isinstance(message, Answer):
        return f"id {message.id} -> host"
    target = "all" if message.id == 0xFF else f"id {message.id}"
    return f"host -> {target}"


@dataclass(frozen=True, slots=True)
class Heard:
    """One sniffed event: seconds since the start, and a frame or rejected bytes."""

    t: float
    event: Event

    @property
    def direction(self) -> str:
        return direction(self.event.message) if isinstance(self.event, SniffedFrame) else "?"

    def text(self) -> str:
        e = self.event
        if isinstance(e, SniffedFrame):
            m = e.message
            return f"{self.t:10.4f}  {self.direction:16s} {m.name:24s} {m.physical()}"
        return f"{self.t:10.4f}  {'?':16s} {'(no frame)':24s} {e.reason}: {e.raw.hex(' ')}"

    def to_dict(self) -> dict[str, Any]:
        e = self.event
        if isinstance(e, SniffedFrame):
            m = e.message
            return {
                "t": round(self.t, 6),
                "dir": self.direction,
                "message": m.name,
                "id": m.id,
                "hex": e.raw.hex(" "),
                "fields": m.fields(),
                "physical": m.physical(),
            }
        return {"t": round(self.t, 6), "dir": "?", "error": e.reason, "hex": e.raw.hex(" ")}


class Sniffer:
    """Bytes heard on a bus (with the time they were heard) -> Heard events."""

    def __init__(self) -> None:
        self.parser = ExplainingParser()
        self.frames = 0
        self.rejected_bytes = 0

    def feed(self, data: bytes, t: float) -> list[Heard]:
        return self._count([Heard(t, e) for e in self.parser.feed(data)])

    def finish(self, t: float) -> list[Heard]:
        """The line went quiet: resolve held bytes."""
        return self._count([Heard(t, e) for e in self.parser.finish()])

    def _count(self, heard: list[Heard]) -> list[Heard]:
        for h in heard:
            if isinstance(h.event, SniffedFrame):
                self.frames += 1
            else:
                self.rejected_bytes += len(h.event.raw)
        return heard
