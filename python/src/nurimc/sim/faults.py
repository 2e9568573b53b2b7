"""Seeded, reproducible fault injection on the wire (random.Random(seed): same seed, same faults)."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass


@dataclass(frozen=True)
class FaultConfig:
    """Probabilities are per byte (drop, flip, noise) or per answer (delay, miss)."""

    drop_rate: float = 0.0  # a byte on the wire (either direction) is lost
    flip_rate: float = 0.0  # one bit of a byte on the wire is inverted
    noise_rate: float = 0.0  # a burst of 1..noise_max random bytes appears before a byte the host gets
    noise_max: int = 8
    delay_ms: float = 0.0  # an answer starts this much later ...
    delay_rate: float = 1.0  # ... with this probability
    miss_rate: float = 0.0  # a controller does not answer at all
    dup_rate: float = 0.0  # an answer arrives twice, back to back (a repeating adapter or line)
    echo: bool = False  # the adapter echoes the host's own bytes back to it
    # A frame the host gets has two bytes changed by +d and -d: the checksum still holds, so the
    # frame is taken as valid with wrong values (noise an 8-bit sum cannot catch; issue 21).
    same_sum_rate: float = 0.0

    def __post_init__(self) -> None:
        for name in ("drop_rate", "flip_rate", "noise_rate", "delay_rate", "miss_rate", "same_sum_rate", "dup_rate"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:
                raise ValueError(f"fault {name} = {value} is not a probability; use 0..1")
        if not (math.isfinite(self.delay_ms) and 0 <= self.delay_ms <= 60_000):
            raise ValueError(f"fault delay_ms = {self.delay_ms}: use a number of milliseconds, 0..60000")
        if self.noise_max < 1:
            raise ValueError(f"fault noise_max = {self.noise_max}; use 1 or more")

    @property
    def active(self) -> bool:
        return bool(
            self.drop_rate
            or self.flip_rate
            or self.noise_rate
            or self.delay_ms
            or self.miss_rate
            or self.dup_rate
            or self.echo
            or self.same_sum_rate
        )


class FaultInjector:
    """Applies a FaultConfig with its own generator, so runs with one seed are identical."""

    def __init__(self, config: FaultConfig, seed: int) -> None:
        self.config = config
        self.rng = random.Random(seed)
        self.counts = {
            "dropped": 0,
            "flipped": 0,
            "noise_bursts": 0,
            "delayed": 0,
            "missed": 0,
            "same_sum": 0,
            "duplicated": 0,
        }
        self._same_sum = SameSum(self.rng, config.same_sum_rate, self.counts) if config.same_sum_rate else None

    def corrupt(self, data: bytes, noise: bool) -> bytes:
        """The bytes as they arrive after drops, bit flips and (towards the host) noise bursts."""
        c, rng = self.config, self.rng
        if noise and self._same_sum is not None:
            data = self._same_sum.feed(data)
        if not (c.drop_rate or c.flip_rate or (noise and c.noise_rate)):
            return data
        out = bytearray()
        for byte in data:
            if noise and c.noise_rate and rng.random() < c.noise_rate:
                out += rng.randbytes(rng.randint(1, c.noise_max))
                self.counts["noise_bursts"] += 1
            if c.drop_rate and rng.random() < c.drop_rate:
                self.counts["dropped"] += 1
                continue
            if c.flip_rate and rng.random() < c.flip_rate:
                byte ^= 1 << rng.randrange(8)
                self.counts["flipped"] += 1
            out.append(byte)
        return bytes(out)

    def answer_delay(self) -> float | None:
        """Extra seconds before an answer starts, or None if the answer goes missing."""
        c, rng = self.config, self.rng
        if c.miss_rate and rng.random() < c.miss_rate:
            self.counts["missed"] += 1
            return None
        if c.delay_ms and rng.random() < c.delay_rate:
            self.counts["delayed"] += 1
            return c.delay_ms / 1000
        return 0.0

    def duplicate(self) -> bool:
        """Does this answer arrive twice?"""
        if self.config.dup_rate and self.rng.random() < self.config.dup_rate:
            self.counts["duplicated"] += 1
            return True
        return False


class SameSum:
    """Follows the frames in the bytes towards the host, however they are cut into chunks, and
    changes two bytes of a frame by +d and -d (mod 256) with probability `rate` per frame.

    The bytes changed lie among the checksum and the data (never header, ID, size or mode), so
    the sum ~(ID + size + mode + data) still matches: the host takes a valid frame with wrong
    values, as when two noise bytes displace two bytes of the same sum on a real line."""

    def __init__(self, rng: random.Random, rate: float, counts: dict[str, int]) -> None:
        self.rng, self.rate, self.counts = rng, rate, counts
        self.offset = -1  # where the current byte lies in a frame (-1: looking for a header)
        self.previous = -1
        self.length = 0
        self.plan: dict[int, int] = {}  # frame offset -> delta

    def feed(self, data: bytes) -> bytes:
        out = bytearray(data)
        for index, byte in enumerate(data):
            if self.offset < 0:
                if self.previous == 0xFF and byte == 0xFE:
                    self.offset = 1
            else:
                self.offset += 1
                if self.offset == 3:
                    self._plan(byte)
                elif self.offset in self.plan:
                    out[index] = (byte + self.plan[self.offset]) & 0xFF
                if self.offset >= 3 and self.offset >= self.length - 1:
                    self.offset = -1
                    byte = -1  # a frame's last byte starts no header
            self.previous = byte
        return bytes(out)

    def _plan(self, size: int) -> None:
        """At the size byte: the frame's length, and whether (and where) to change it."""
        self.length = size + 4
        self.plan = {}
        if not 3 <= size <= 10:  # no message has this size; or one without data (only the checksum to change)
            if not 2 <= size <= 10:
                self.offset = -1
            return
        if self.rng.random() >= self.rate:
            return
        first, second = self.rng.sample([4, *range(6, self.length)], 2)  # the checksum and the data bytes
        delta = self.rng.randrange(1, 256)
        self.plan = {first: delta, second: -delta}
        self.counts["same_sum"] += 1
