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

    def __post_init__(self) -> None:
        for name in ("drop_rate", "flip_rate", "noise_rate", "delay_rate", "miss_rate", "dup_rate"):
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
        )


class FaultInjector:
    """Applies a FaultConfig with its own generator, so runs with one seed are identical."""

    def __init__(self, config: FaultConfig, seed: int) -> None:
        self.config = config
        self.rng = random.Random(seed)
        self.counts = {"dropped": 0, "flipped": 0, "noise_bursts": 0, "delayed": 0, "missed": 0, "duplicated": 0}

    def corrupt(self, data: bytes, noise: bool) -> bytes:
        """The bytes as they arrive after drops, bit flips and (towards the host) noise bursts."""
        c, rng = self.config, self.rng
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
