"""Step a procedure by hand (h11 style): feed each action its result, look at the next one.

No port, no thread, no real clock: time is a number the test moves. Clock actions (Now, Wait,
WaitUntil) and Discard/Note are answered here as the drivers would (Discard: nothing
received); the actions that touch the bus (Send, Receive, SetHostBaud) stop the stepper, so the
test asserts on them and decides what the wire does.
"""

from __future__ import annotations

from typing import Any, Generic, TypeVar

from nurimc.core.actions import Action, Discard, Note, Now, Procedure, Receive, Send, Sent, SetHostBaud, Wait, WaitUntil

T = TypeVar("T")


class Finished(Exception):
    """The procedure returned (value) while the test expected another action."""


class Stepper(Generic[T]):
    def __init__(self, procedure: Procedure[T], clock: float = 100.0) -> None:
        self.procedure = procedure
        self.clock = clock
        self.notes: list[Any] = []
        self.waits: list[Action] = []  # clock actions that let time pass, in order
        self.done = False
        self.value: T | None = None
        self.action: Action | None = None
        self._advance(lambda: next(procedure))

    # -- driving ---------------------------------------------------------------------------
    def _advance(self, step: Any) -> None:
        """Run until the next bus action (Send, Receive, SetHostBaud) or the end."""
        try:
            action = step()
            while type(action) in (Now, Wait, WaitUntil, Discard, Note):
                if type(action) is Now:
                    result: Any = self.clock
                elif type(action) is Wait:
                    self.waits.append(action)
                    self.clock += action.seconds
                    result = None
                elif type(action) is WaitUntil:
                    self.waits.append(action)
                    self.clock = max(self.clock, action.when)
                    result = self.clock
                elif type(action) is Discard:
                    result = b""
                else:
                    self.notes.append(action.event)
                    result = None
                action = self.procedure.send(result)
            self.action = action
        except StopIteration as stop:
            self.done, self.value, self.action = True, stop.value, None

    def expect(self, kind: type) -> Any:
        if self.done:
            raise Finished(f"expected {kind.__name__}, the procedure returned {self.value!r}")
        assert type(self.action) is kind, f"expected {kind.__name__}, got {self.action!r}"
        return self.action

    def sent(self, wire_time: float = 0.0) -> bytes:
        """The pending action must be a Send: it goes out now; returns its bytes."""
        send: Send = self.expect(Send)
        started = self.clock
        self.clock += wire_time
        self._advance(lambda: self.procedure.send(Sent(started, self.clock)))
        return send.data

    def receive(self, data: bytes) -> Receive:
        """The pending action must be a Receive: `data` arrives (b"": its time ran out)."""
        receive: Receive = self.expect(Receive)
        if not data:
            self.clock = max(self.clock, receive.until)
        self._advance(lambda: self.procedure.send(data))
        return receive

    def silence(self) -> None:
        """Let every pending Receive time out until the next non-Receive action."""
        while not self.done and type(self.action) is Receive:
            self.receive(b"")

    def baud(self) -> int:
        change: SetHostBaud = self.expect(SetHostBaud)
        self._advance(lambda: self.procedure.send(None))
        return change.rate

    def fail(self, error: BaseException) -> None:
        """The pending action failed (a port error, a timeout, a cancellation): throw it in."""
        assert not self.done
        self._advance(lambda: self.procedure.throw(error))

    def result(self) -> T:
        assert self.done, f"the procedure still wants {self.action!r}"
        return self.value  # type: ignore[return-value]
