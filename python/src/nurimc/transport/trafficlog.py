"""Traffic logs: every byte sent and received, timestamped, one JSON object a line:
{"t": seconds since the log opened, "dir": "tx"|"rx", "hex": "..."}.

Written by `TrafficLog` (a bus's `log=`, `nurimc sniff --log`, the console's export, the embedded
runs); read by `read_traffic_log` (`nurimc replay`, the MCAP converter, the logic-analyzer
import). Decoded frames are added when a log is replayed, so logging costs little on the hot path.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any, Protocol

from ..budgets import ReadBudget, default_budget
from ..errors import InputError
from ..inputs import json_document, number, show
from ..protocol import Message, StreamParser

#: a longer line is no traffic log line (a frame is at most 14 bytes; a log line of a burst, some kB)
LOG_LINE_LIMIT = 1 << 20


def read_traffic_log(path: str, budget: ReadBudget | None = None) -> list[tuple[float, str, bytes]]:
    """Every line of a traffic log as (t, dir, bytes); InputError naming file, line and field if
    a line is not one a traffic log holds ({"t": seconds, "dir": "tx"|"rx", "hex": "..."}), or
    if it holds more than the budget's records (nurimc.budgets)."""
    budget = budget or default_budget()
    lines: list[tuple[float, str, bytes]] = []
    with open(path, "rb") as file:
        for number_, raw in enumerate(iter(lambda: file.readline(LOG_LINE_LIMIT + 1), b""), 1):
            where = f"{path} line {number_}"
            if len(raw) > LOG_LINE_LIMIT:
                raise InputError(f"{where}: longer than {LOG_LINE_LIMIT} bytes; not a traffic log line")
            if not raw.strip():
                continue
            if len(lines) >= budget.records:
                raise budget.over(f"{path}: lines", budget.records)
            entry = json_document(raw, where, "a traffic log line")
            if not isinstance(entry, dict):
                raise InputError(f"{where}: {show(entry)} is not a JSON object with t, dir and hex")
            t = number(entry.get("t"), f"{where}: t", 0, None, "s")
            direction = entry.get("dir")
            if direction not in ("tx", "rx"):
                raise InputError(f"{where}: dir {show(direction)} is not tx or rx")
            text = entry.get("hex")
            try:
                data = bytes.fromhex(text) if isinstance(text, str) else None
            except ValueError:
                data = None
            if data is None:
                raise InputError(f"{where}: hex {show(text)} is not hex bytes")
            lines.append((t, direction, data))
    return lines


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
