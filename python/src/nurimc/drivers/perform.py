"""Carrying out actions, once for both drivers (docs/drivers.md).

`steps` is the trampoline: it steps a procedure, performs every action that does not
block (send, discard, baud, note, the clock) itself, and hands the driver only what blocks,
as a `ReadFor` or a `SleepFor` already cut to the call's deadline. The sync and asyncio
drivers differ in just how they carry those two out. `run_in_place` is the same loop for the
sync driver, which calls its read and sleep where `steps` yields (the request path's cost,
docs/performance.md); what a blocking action asks and what it returns (`_blocking`,
`_blocked`) is shared by both.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from ..core.actions import Action, Discard, Note, Now, Procedure, Receive, Send, Sent, SetHostBaud, Wait, WaitUntil
from ..core.clock import REAL_CLOCK, Clock
from ..errors import CallTimeout
from ..transport import Transport
from ..transport.trafficlog import FrameRecorder

#: how long a read that starts after its deadline still looks for bytes that already came
LATE_READ = 0.0005
#: late reads go on while they find bytes, for at most this long (what already came is read at once)
LATE_READS_FOR = 0.005

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class ReadFor:
    """Blocking: read up to max_bytes from the transport, waiting at most `seconds`. Result: bytes."""

    max_bytes: int
    seconds: float


@dataclass(frozen=True, slots=True)
class SleepFor:
    """Blocking: let `seconds` pass on the driver's clock. Result: None."""

    seconds: float


Blocking = ReadFor | SleepFor
Steps = Generator[Blocking, Any, T]


class Performer:
    """Performs the non-blocking actions and hands every byte to the listeners."""

    __slots__ = (
        "_late_read_for",
        "_late_read_found",
        "_late_reads_began",
        "clock",
        "listeners",
        "on_note",
        "transport",
    )

    def __init__(
        self,
        transport: Transport,
        listeners: Sequence[FrameRecorder] = (),
        on_note: Callable[[Any], None] | None = None,
        clock: Clock | None = None,
    ) -> None:
        self.transport = transport
        self.listeners = tuple(listeners)
        self.on_note = on_note
        self.clock: Clock = clock or REAL_CLOCK
        self._late_read_for: float | None = None
        self._late_read_found = False
        self._late_reads_began = 0.0

    def read_timeout(self, until: float) -> float | None:
        """Seconds to wait in a read ending at `until`, or None: no read, time is up.

        Once `until` has passed, short reads still take what arrived meanwhile (as long as each
        finds bytes: several answers may be waiting), so a host that woke late (loaded) loses
        nothing; the first late read that finds nothing ends the wait."""
        now = self.clock.now()
        remaining = until - now
        if remaining > 0:
            return remaining
        if self._late_read_for == until:
            # bytes that already arrived are taken at once; a line that keeps babbling is not
            # read past LATE_READS_FOR after the first late read
            if not self._late_read_found or now - self._late_reads_began >= LATE_READS_FOR:
                return None
        else:
            self._late_read_for, self._late_reads_began = until, now
        self._late_read_found = False
        return LATE_READ

    def received(self, data: bytes) -> bytes:
        self._late_read_found = bool(data)
        if data:
            for listener in self.listeners:
                listener.record("rx", data)
        return data

    def perform(self, action: Action) -> Any:
        kind = type(action)
        if kind is Send:
            now = self.clock.now
            started = now()
            self.transport.write(action.data)  # type: ignore[union-attr]
            sent = Sent(started, now())
            for listener in self.listeners:
                listener.record("tx", action.data)  # type: ignore[union-attr]
            return sent
        if kind is Discard:
            return self.received(self.transport.discard_input())
        if kind is Now:
            return self.clock.now()
        if type(action) is SetHostBaud:
            self.transport.baudrate = action.rate
            return None
        if type(action) is Note:
            if self.on_note:
                self.on_note(action.event)
            return None
        raise TypeError(f"not a non-blocking action: {action!r}")


def steps(procedure: Procedure[T], performer: Performer, timeout: float | None = None) -> Steps[T]:
    """Step `procedure` to its end, yielding only what blocks (the driver performs it and sends
    the result back, or throws its error in).

    An error performing an action (a port that fails, an interrupt, a cancellation) is thrown
    into the procedure at the action that failed, so its `except`/`finally` can restore the
    bus; when `timeout` seconds have passed, CallTimeout is thrown in at the next blocking
    action. A procedure left unfinished is closed. (`run_in_place` is the same loop for a
    driver that blocks where it stands: keep the two alike.)"""
    clock = performer.clock
    now = clock.now
    perform = performer.perform
    call_deadline = None if timeout is None else now() + timeout
    result: Any = None
    error: BaseException | None = None
    send = procedure.send
    try:
        while True:
            try:
                action: Action = send(result) if error is None else procedure.throw(error)
            except StopIteration as stop:
                return stop.value  # type: ignore[no-any-return]
            result, error = None, None
            try:
                kind = type(action)
                if kind is Now:  # the commonest action, answered here
                    result = now()
                elif kind is Receive or kind is Wait or kind is WaitUntil:
                    if call_deadline is not None and now() >= call_deadline:
                        call_deadline = None  # thrown once; the procedure's cleanup may still use the bus
                        raise CallTimeout(f"the bus call took longer than {timeout:g} s and was abandoned")
                    block = _blocking(action, performer, call_deadline)
                    result = _blocked(action, performer, block, (yield block) if block is not None else b"")
                else:
                    result = perform(action)
            except BaseException as err:  # every failure goes to the procedure (docs/drivers.md)
                error = err
    finally:
        procedure.close()


def run_in_place(
    procedure: Procedure[T],
    performer: Performer,
    timeout: float | None,
    read: Callable[[int, float], bytes],
    sleep: Callable[[float], None],
) -> T:
    """`steps` for a driver that blocks where it stands (the sync Bus): the same stepping, error
    routing and call timeout, with what blocks carried out by calling `read` and `sleep` instead
    of yielding it to a second loop (one generator switch less per action; docs/performance.md)."""
    clock = performer.clock
    now = clock.now
    perform = performer.perform
    transport, listeners = performer.transport, performer.listeners
    call_deadline = None if timeout is None else now() + timeout
    result: Any = None
    error: BaseException | None = None
    send = procedure.send
    try:
        while True:
            try:
                action: Action = send(result) if error is None else procedure.throw(error)
            except StopIteration as stop:
                return stop.value  # type: ignore[no-any-return]
            result, error = None, None
            try:
                kind = type(action)
                if kind is Now:  # the commonest actions, carried out here (as Performer.perform does)
                    result = now()
                elif kind is Send and not listeners:
                    started = now()
                    transport.write(action.data)  # type: ignore[union-attr]
                    result = Sent(started, now())
                elif kind is Discard and not listeners:
                    result = performer.received(transport.discard_input())
                elif kind is Receive or kind is Wait or kind is WaitUntil:
                    if call_deadline is not None and now() >= call_deadline:
                        call_deadline = None  # thrown once; the procedure's cleanup may still use the bus
                        raise CallTimeout(f"the bus call took longer than {timeout:g} s and was abandoned")
                    block = _blocking(action, performer, call_deadline)
                    if block is None:
                        data = b""
                    elif type(block) is ReadFor:
                        data = read(block.max_bytes, block.seconds)
                    else:
                        data = b""
                        sleep(block.seconds)
                    result = _blocked(action, performer, block, data)
                else:
                    result = perform(action)
            except BaseException as err:  # every failure goes to the procedure (docs/drivers.md)
                error = err
    finally:
        procedure.close()


def _blocking(action: Action, performer: Performer, call_deadline: float | None) -> Blocking | None:
    """What a blocking action asks of the driver, cut to the call's deadline (None: nothing)."""
    kind = type(action)
    if kind is Receive:
        until = action.until if call_deadline is None else min(action.until, call_deadline)  # type: ignore[union-attr]
        wait = performer.read_timeout(until)
        return None if wait is None else ReadFor(action.max_bytes, wait)  # type: ignore[union-attr]
    clock = performer.clock
    if kind is Wait:
        seconds = action.seconds if call_deadline is None else min(action.seconds, call_deadline - clock.now())  # type: ignore[union-attr]
        return SleepFor(seconds) if seconds > 0 else None
    assert kind is WaitUntil
    when = action.when if call_deadline is None else min(action.when, call_deadline)  # type: ignore[union-attr]
    delay = when - clock.now()
    return SleepFor(delay) if delay > 0 else None


def _blocked(action: Action, performer: Performer, block: Blocking | None, data: Any) -> Any:
    """The action's result once the driver has done what `_blocking` asked (`data`: what it read)."""
    kind = type(action)
    if kind is Receive:
        return b"" if block is None else performer.received(data)
    if kind is Wait:
        return None
    return performer.clock.now()
