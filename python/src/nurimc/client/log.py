"""Traffic log: every byte sent and received, timestamped, as JSON lines.

Each line: {"t": seconds since the log opened, "dir": "tx"|"rx", "hex": "..."}; decoded frames
are added when the log is replayed (`nurimc replay LOG`), so logging costs little on the hot path.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any, Protocol

from ..protocol import Message, StreamParser


class FrameRecorder(Protocol):
    """Anything that wants the raw bytes of the bus as they pass ("tx" or "rx")."""

    def record(self, direction: str, data: bytes) -> None: ...

    def close(self) -> None: ...


class TrafficLog:
    def __init__(self, path: str | Path) -> None:
        self._file: IO[str] = open(path, "a", encoding="utf-8")  # noqa: SIM115 - closed in close()
        self._start = time.monotonic()

    def record(self, direction: str, data: bytes) -> None:
        t = round(time.monotonic() - self._start, 6)
        self._file.write(json.dumps({"t": t, "dir": direction, "hex": data.hex()}) + "\n")

    def close(self) -> None:
        self._file.close()


def replay(path: str | Path) -> Iterator[dict[str, Any]]:
    """Yield each decoded frame of a log: {"t", "dir", "message": Message} or {"t","dir","error"}.

    Each direction has its own parser, so chunks split across lines are reassembled.
    """
    parsers = {"tx": StreamParser(), "rx": StreamParser()}
    with open(path, encoding="utf-8") as lines:
        for number, line in enumerate(lines, 1):
            try:
                entry = json.loads(line)
                data = bytes.fromhex(entry["hex"])
                parser = parsers[entry["dir"]]
            except (ValueError, KeyError, TypeError) as err:
                yield {"line": number, "error": f"not a traffic log line ({err})"}
                continue
            before = parser.stats.dropped_bytes
            frames: list[Message] = parser.feed(data)
            for message in frames:
                yield {"t": entry.get("t"), "dir": entry["dir"], "message": message}
            if parser.stats.dropped_bytes > before:
                yield {
                    "t": entry.get("t"),
                    "dir": entry["dir"],
                    "error": f"{parser.stats.dropped_bytes - before} bytes of noise",
                }
