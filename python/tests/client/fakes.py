"""A scripted transport: a function decides what comes back for each write. No clocks, no waits."""

from __future__ import annotations

from collections.abc import Callable


class ScriptedTransport:
    url = "scripted://"
    latency = 0.0

    def __init__(self, respond: Callable[[bytes], bytes]) -> None:
        self.respond = respond
        self.written: list[bytes] = []
        self.inbox = bytearray()
        self._baud = 9600

    @property
    def baudrate(self) -> int:
        return self._baud

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        self._baud = rate

    def write(self, data: bytes) -> None:
        self.written.append(data)
        self.inbox += self.respond(data)

    def read(self, max_bytes: int, timeout: float) -> bytes:
        data = bytes(self.inbox[:max_bytes])
        del self.inbox[:max_bytes]
        return data

    def discard_input(self) -> bytes:
        data = bytes(self.inbox)
        self.inbox.clear()
        return data

    def close(self) -> None:
        pass
