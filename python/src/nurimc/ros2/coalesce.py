"""The bridge's command queue: latest wins, a stop wins over everything queued before it.

DDS delivers commands on Cyclone's threads; the bus thread carries them out between readings.
A publisher can send far faster than a serial bus can carry (a 10,000/s flood; a controller
manager at 1 kHz), so a queue that kept every command would grow without bound and each
command would reach the motor later than the one before. Instead:

- A motion command (`position`, `velocity`: one value per joint, so it covers every joint)
  replaces any motion command still queued: the bus only ever carries the latest one.
- Work with a key (ros2_control's JointState commands by joint name, the base's cmd_vel)
  replaces queued work of the same key: latest wins per joint, per topic.
- An estop drops everything queued before it (estops keep their order among themselves).
- Anything else (unkeyed work) keeps its order.

So the queue holds at most one motion command, one piece of work per key, and the estops:
its length is bounded whatever the publishers do. `dropped` counts what was replaced, for
/diagnostics ("coalesced_commands").
"""

from __future__ import annotations

from collections import deque
from typing import Any

MOTION = frozenset({"position", "velocity"})


class CommandQueue:
    """Not thread-safe by itself: the node holds its lock around every call."""

    def __init__(self) -> None:
        self._events: deque[tuple[str, Any, str | None]] = deque()
        self.dropped = 0

    def __len__(self) -> int:
        return len(self._events)

    def __bool__(self) -> bool:
        return bool(self._events)

    def push(self, kind: str, value: Any, key: str | None = None) -> None:
        if kind == "estop":
            kept = [e for e in self._events if e[0] == "estop"]
            self.dropped += len(self._events) - len(kept)
            self._events = deque(kept)
        elif kind in MOTION:
            self._drop(lambda e: e[0] in MOTION)
        elif key is not None:
            self._drop(lambda e: e[2] == key)
        self._events.append((kind, value, key))

    def _drop(self, same: Any) -> None:
        before = len(self._events)
        self._events = deque(e for e in self._events if not same(e))
        self.dropped += before - len(self._events)

    def has_estop(self) -> bool:
        return any(e[0] == "estop" for e in self._events)

    def pop(self) -> tuple[str, Any] | None:
        """The next event to carry out (kind, value), or None."""
        if not self._events:
            return None
        kind, value, _ = self._events.popleft()
        return kind, value

    def clear(self) -> None:
        self._events.clear()
