"""The bus's counters for the console's status bar (sent with every heartbeat tick)."""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import Any

#: frames/s is the change of the bus's frame count over at least this long (server clock), s
RATE_WINDOW = 1.0


class FrameRate:
    """Frames per second on the wire, from the bus's own counters (requests + answers) and the
    server's clock at the moment it reads them: never from when the figures reach the page (a
    tab that was busy gets several ticks at once, which made 16,738 frames/s at 115,200 bps)."""

    def __init__(self, window: float = RATE_WINDOW, clock: Callable[[], float] = time.monotonic) -> None:
        self.window = window
        self.clock = clock
        self._history: deque[tuple[float, int]] = deque()

    def update(self, frames: int) -> float | None:
        """The rate over the last `window` seconds (or since the first count); None at first."""
        now = self.clock()
        self._history.append((now, frames))
        while len(self._history) > 2 and now - self._history[1][0] >= self.window:
            self._history.popleft()
        then, before = self._history[0]
        if now - then <= 0:
            return None
        return max(0.0, (frames - before) / (now - then))


def bus_stats(bus: Any, rate: FrameRate | None = None) -> dict[str, Any] | None:
    """Errors, stale answers and busy waits of the bus so far; None if the bus has no counters.
    With `rate`: also frames_per_second, measured where the frames happen (FrameRate).

    Read from the bus thread's counters without a lock: plain integers, read for display only
    (a count off by one for a tick is harmless)."""
    stats = getattr(bus, "stats", None)
    if stats is None:
        return None
    out: dict[str, Any] = {
        "requests": int(stats.requests),
        "answers": int(stats.answers),
        "errors": int(stats.no_answer),
        "retries": int(stats.retries),
        "stale": int(stats.stale_frames),
        "busy_waits": int(stats.busy_waits),
        "quiet_waits": int(stats.quiet_waits),
        "dropped_bytes": int(stats.dropped_bytes),
    }
    if rate is not None:
        per_second = rate.update(out["requests"] + out["answers"])
        out["frames_per_second"] = None if per_second is None else round(per_second, 1)
    return out
