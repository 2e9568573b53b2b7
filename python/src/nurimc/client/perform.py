"""Carrying out actions for both drivers (docs/drivers.md).

Only Receive, Wait and WaitUntil block; the sync and asyncio drivers differ in just those.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from ..transport import Transport
from .actions import Action, Discard, Note, Now, Send, Sent, SetHostBaud
from .log import FrameRecorder

#: how long a read that starts after its deadline still looks for bytes that already came
LATE_READ = 0.0005


class Performer:
    """Performs the non-blocking actions and hands every byte to the listeners."""

    def __init__(
        self,
        transport: Transport,
        listeners: Sequence[FrameRecorder] = (),
        on_note: Callable[[Any], None] | None = None,
    ) -> None:
        self.transport = transport
        self.listeners = tuple(listeners)
        self.on_note = on_note
        self._late_read_for: float | None = None

    def read_timeout(self, until: float) -> float | None:
        """Seconds to wait in a read ending at `until`, or None: no read, time is up.

        Once `until` has passed, one short read still takes what arrived meanwhile, so a host
        that woke late (loaded) loses nothing; the next read for that `until` ends the wait."""
        remaining = until - time.monotonic()
        if remaining > 0:
            return remaining
        if self._late_read_for == until:
            return None
        self._late_read_for = until
        return LATE_READ

    def received(self, data: bytes) -> bytes:
        if data:
            for listener in self.listeners:
                listener.record("rx", data)
        return data

    def perform(self, action: Action) -> Any:
        if type(action) is Send:
            started = time.monotonic()
            self.transport.write(action.data)
            sent = Sent(started, time.monotonic())
            for listener in self.listeners:
                listener.record("tx", action.data)
            return sent
        if type(action) is Now:
            return time.monotonic()
        if type(action) is Discard:
            return self.received(self.transport.discard_input())
        if type(action) is SetHostBaud:
            self.transport.baudrate = action.rate
            return None
        if type(action) is Note:
            if self.on_note:
                self.on_note(action.event)
            return None
        raise TypeError(f"not a non-blocking action: {action!r}")
