"""The one small interface every transport implements (python-can style)."""

from __future__ import annotations

from typing import Protocol


class Transport(Protocol):
    """A half-duplex byte pipe to the bus."""

    url: str
    #: Seconds an adapter may hold received bytes before the host sees them (USB adapters: 1-16 ms).
    latency: float

    @property
    def baudrate(self) -> int: ...

    @baudrate.setter
    def baudrate(self, rate: int) -> None: ...

    def write(self, data: bytes) -> None: ...

    def read(self, max_bytes: int, timeout: float) -> bytes:
        """Up to max_bytes: returns as soon as that many arrived, or what came by the timeout."""
        ...

    def discard_input(self) -> bytes:
        """Drop (and return) bytes already received: stale answers, noise."""
        ...

    def close(self) -> None: ...
