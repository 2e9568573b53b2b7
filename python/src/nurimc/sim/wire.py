"""The shared half-duplex wire: transmissions in time, collisions, and bytes at the wrong rate.

Every controller transmission occupies [start, start + bytes * 10 / baud) on the wire,
whether or not wire timing paces delivery. Transmissions whose windows overlap collide:
RS485 drivers fight and the idle-high line reads as the AND of what they send; the
receiver's UART decodes that line (see merge). Staggered response times avoid this.
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


def line_bits(data: bytes | bytearray) -> list[int]:
    """The line level, bit by bit, of 8N1 characters: start 0, data LSB first, stop 1."""
    bits: list[int] = []
    for byte in data:
        bits.append(0)
        bits.extend((byte >> i) & 1 for i in range(8))
        bits.append(1)
    return bits


def uart_decode(bits: list[int]) -> bytearray:
    """What a UART reads from a line: each falling edge starts a character of 8 data bits."""
    out = bytearray()
    i, n = 0, len(bits)
    while i < n:
        if bits[i]:
            i += 1
            continue
        value = 0
        for k in range(8):
            j = i + 1 + k
            value |= (bits[j] if j < n else 1) << k
        out.append(value)
        i += 10
    return out


def merge(a: Transmission, b: Transmission) -> Transmission:
    """What a receiver reads when `a` and `b` overlap (neither delivered yet).

    The line is the AND of both drivers. Two controllers never share a bit clock, so the
    later one is at least one bit out of step (identical answers sent "at once" still
    garble); the result is decoded as a UART would.
    """
    first, second = (a, b) if a.start <= b.start else (b, a)
    bit = first.byte_time / 10
    shift = max(1, round((second.start - first.start) / bit))
    ones, twos = line_bits(first.data), line_bits(second.data)
    line = [1] * max(len(ones), shift + len(twos))
    line[: len(ones)] = ones
    for i, level in enumerate(twos):
        line[shift + i] &= level
    return Transmission(first.start, first.baud, uart_decode(line), first.sources + second.sources)


class Garbler:
    """What a UART set to one rate reads from bytes sent at another: a different number of
    random bytes, never 0xFF, so never a frame header (and never a frame)."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    def garble(self, data: bytes, sent_baud: int, heard_baud: int) -> bytes:
        count = max(1, round(len(data) * heard_baud / sent_baud)) if data else 0
        return bytes(self.rng.randrange(0xFF) for _ in range(count))
