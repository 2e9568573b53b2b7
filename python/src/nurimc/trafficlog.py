"""Traffic logs as `nurimc sniff --log`, the console's export and the embedded runs write them:
one JSON object a line, {"t": seconds, "dir": "tx"|"rx", "hex": "..."}. Read by `nurimc replay`,
the MCAP converter and the logic-analyzer import (nurimc.sigrok)."""

from __future__ import annotations

from .budgets import ReadBudget, default_budget
from .errors import InputError
from .inputs import json_document, number, show

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
