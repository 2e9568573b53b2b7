"""The bus's counters for the console's status bar (sent with every heartbeat tick)."""

from __future__ import annotations

from typing import Any


def bus_stats(bus: Any) -> dict[str, int] | None:
    """Errors, stale answers and busy waits of the bus so far; None if the bus has no counters.

    Read from the bus thread's counters without a lock: plain integers, read for display only
    (a count off by one for a tick is harmless)."""
    stats = getattr(bus, "stats", None)
    if stats is None:
        return None
    return {
        "requests": int(stats.requests),
        "answers": int(stats.answers),
        "errors": int(stats.no_answer),
        "retries": int(stats.retries),
        "stale": int(stats.stale_frames),
        "busy_waits": int(stats.busy_waits),
        "quiet_waits": int(stats.quiet_waits),
        "dropped_bytes": int(stats.dropped_bytes),
    }
