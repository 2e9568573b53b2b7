"""The raw view's source: every byte the bus sends and receives, decoded into frames."""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any

from ..protocol import Message, ProtocolError, StreamParser, build_frame

KEEP = 5000  # frames kept for a page that opens the raw view late


def _hex(message: Message) -> str:
    try:
        return message.encode().hex(" ")
    except ProtocolError:  # e.g. a broadcast request (ID 255): valid on the wire, refused by the encoder
        spec = message.SPEC
        return build_frame(message.id, spec.mode, spec.layout.pack(*message.fields().values())).hex(" ")


class FrameTap:
    """A Bus tracer: decodes each direction with its own parser and keeps the recent frames."""

    def __init__(self) -> None:
        self._parsers = {"tx": StreamParser(), "rx": StreamParser()}
        self._lock = threading.Lock()
        self._start = time.monotonic()
        self.recent: deque[dict[str, Any]] = deque(maxlen=KEEP)
        self._pending: list[dict[str, Any]] = []
        self.enabled = False  # decoding costs little, but nothing is queued unless a page watches

    def record(self, direction: str, data: bytes) -> None:
        try:
            self._record(direction, data)
        except Exception as error:
            with self._lock:
                self._pending.append(
                    {
                        "t": 0,
                        "dir": direction,
                        "hex": data.hex(" "),
                        "name": "tap error",
                        "id": None,
                        "fields": {"error": str(error)},
                    }
                )

    def _record(self, direction: str, data: bytes) -> None:
        parser = self._parsers.get(direction)
        if parser is None:
            return
        t = round(time.monotonic() - self._start, 6)
        dropped_before = parser.stats.dropped_bytes
        frames = parser.feed(data)
        entries = [
            {"t": t, "dir": direction, "hex": _hex(m), "name": m.name, "id": m.id, "fields": m.physical()}
            for m in frames
        ]
        noise = parser.stats.dropped_bytes - dropped_before
        if noise:
            entries.append(
                {"t": t, "dir": direction, "hex": "", "name": "noise", "id": None, "fields": {"bytes": noise}}
            )
        with self._lock:
            self.recent.extend(entries)
            if self.enabled:
                self._pending.extend(entries)

    def take(self) -> list[dict[str, Any]]:
        with self._lock:
            out, self._pending = self._pending, []
            return out

    def close(self) -> None:
        pass
