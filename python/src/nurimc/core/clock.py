"""The clock a driver runs procedures on: the real one, or virtual time shared with the simulator.

A driver reads the time and lets it pass only through its clock (docs/architecture.md, "The
clock"). `RealClock` is the monotonic clock of the host. `VirtualClock` is time that moves only
when someone waits: give the same one to a `SimBus(clock=...)` and to a `Bus(..., clock=...)`,
and a read that finds nothing moves time to the simulator's next byte (or to the read's end)
instead of sleeping. Library and simulator then run on virtual time: fast, and the same on a
loaded host as on an idle one.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable


@runtime_checkable
class Clock(Protocol):
    """What a driver needs of time: read it, and let it pass (blocking or awaited)."""

    def now(self) -> float: ...
    def sleep(self, seconds: float) -> None: ...
    async def sleep_async(self, seconds: float) -> None: ...


#: A wait this short (s) is spun, reading the clock until it has passed, rather than slept: the
#: system's sleep wakes up to its timer slack late (50 us on Linux) and costs two context switches,
#: more CPU than the wait itself. The bus's waits of a few byte times (the duplicate gap between
#: two equal requests: 20 us at 1 Mbps) are this short (docs/performance.md).
SPIN = 50e-6


class RealClock:
    """The host's monotonic clock; sleeping really sleeps."""

    #: time.monotonic itself: a driver reads the clock several times a request
    now = staticmethod(time.monotonic)

    def __call__(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > SPIN:
            time.sleep(seconds)
        elif seconds > 0:  # too short to sleep: read the clock until it has passed
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                pass

    async def sleep_async(self, seconds: float) -> None:
        import asyncio  # here: a sync program (the CLI) never loads asyncio

        await asyncio.sleep(max(0.0, seconds))


REAL_CLOCK = RealClock()


class VirtualClock:
    """Virtual seconds: `now()` is where time stands; sleeping (or `advance`) moves it at once.

    Callable (`clock()` is `clock.now()`), so it also serves where a plain time function is
    expected. Whoever must follow time (the simulator's physics) registers with `on_advance`.
    Thread-safe: time only moves forward, and callbacks run in the thread that moved it."""

    def __init__(self, start: float = 100.0) -> None:
        self._t = start
        self._lock = threading.RLock()
        self._followers: list[Callable[[float], None]] = []

    def now(self) -> float:
        return self._t

    def __call__(self) -> float:
        return self._t

    @property
    def t(self) -> float:
        """The present time (settable: setting it is advance_to)."""
        return self._t

    @t.setter
    def t(self, when: float) -> None:
        self.advance_to(when)

    def on_advance(self, follower: Callable[[float], None]) -> None:
        """Call `follower(now)` after every move of time."""
        with self._lock:
            self._followers.append(follower)

    def advance_to(self, when: float) -> None:
        with self._lock:
            if when <= self._t:
                return
            self._t = when
            followers = list(self._followers)
        for follower in followers:
            follower(when)

    def advance(self, seconds: float) -> None:
        self.advance_to(self._t + seconds)

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self.advance(seconds)

    async def sleep_async(self, seconds: float) -> None:
        self.sleep(seconds)
        import asyncio

        await asyncio.sleep(0)  # other tasks still get their turn, as in a real sleep
