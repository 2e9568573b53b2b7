"""Carrying out the actions that never block, for both drivers.

Only Receive and Wait block; the sync and asyncio drivers differ in just those two.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ..transport import Transport
from .actions import Action, Discard, Note, Send, SetBaud
from .log import FrameRecorder


class Performer:
    """Performs Send, Discard, SetBaud and Note; remembers when the last Send went out."""

    def __init__(
        self, transport: Transport, log: FrameRecorder | None = None, on_note: Callable[[Any], None] | None = None
    ) -> None:
        self.transport = transport
        self.log = log
        self.on_note = on_note
        self.sent_at = time.monotonic()

    def remaining(self, deadline: float) -> float:
        """Seconds left until `deadline` seconds after the last Send."""
        return self.sent_at + deadline - time.monotonic()

    def received(self, data: bytes) -> bytes:
        if self.log and data:
            self.log.record("rx", data)
        return data

    def perform(self, action: Action) -> Any:
        if type(action) is Send:
            self.transport.write(action.data)
            self.sent_at = time.monotonic()
            if self.log:
                self.log.record("tx", action.data)
        elif type(action) is Discard:
            return self.received(self.transport.discard_input())
        elif type(action) is SetBaud:
            self.transport.baudrate = action.rate
        elif type(action) is Note:
            if self.on_note:
                self.on_note(action.event)
        else:
            raise TypeError(f"not a non-blocking action: {action!r}")
        return None
