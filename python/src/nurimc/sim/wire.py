"""The shared half-duplex wire: transmissions in time, collisions, and bytes at the wrong rate.

Every controller transmission occupies [start, start + bytes * 10 / baud) on the wire,
whether or not wire timing paces delivery. Transmissions whose windows overlap collide:
RS485 drivers fight and the idle-high line reads as the AND of what they send, so the
overlapping bytes (aligned by byte slot) are ANDed. Staggered response times avoid this.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field


def byte_time(baud: int) -> float:
    """Seconds one 8N1 character takes: 10 bits."""
    return 10.0 / baud


@dataclass
class Transmission:
    start: float
    baud: int
    data: bytearray
    sources: list[int] = field(default_factory=list)  # controller IDs that sent (for the log)
    delivered: int = 0  # bytes already handed to the hosts

    @property
    def byte_time(self) -> float:
        return byte_time(self.baud)

    @property
    def end(self) -> float:
        return self.start + len(self.data) * self.byte_time

    @property
    def collided(self) -> bool:
        return len(self.sources) > 1

    def overlaps(self, other: Transmission) -> bool:
        return self.start < other.end and other.start < self.end


def merge(a: Transmission, b: Transmission) -> Transmission:
    """The bytes a receiver reads when `a` and `b` overlap (neither delivered yet): ANDed per slot."""
    first, second = (a, b) if a.start <= b.start else (b, a)
    offset = round((second.start - first.start) / first.byte_time)
    data = bytearray(first.data)
    for i, byte in enumerate(second.data):
        j = offset + i
        if j < len(data):
            data[j] &= byte
        else:
            data.append(byte)
    return Transmission(first.start, first.baud, data, first.sources + second.sources)


class Garbler:
    """What a UART set to one rate reads from bytes sent at another: a different number of
    random bytes, never 0xFF, so never a frame header (and never a frame)."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    def garble(self, data: bytes, sent_baud: int, heard_baud: int) -> bytes:
        count = max(1, round(len(data) * heard_baud / sent_baud)) if data else 0
        return bytes(self.rng.randrange(0xFF) for _ in range(count))
