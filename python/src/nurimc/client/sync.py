"""The synchronous bus: runs core procedures on a transport, one thread at a time."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from ..errors import CallTimeout
from ..motor import Motor
from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from .actions import Action, Procedure, Receive, Wait, WaitUntil
from .core import BusCore
from .log import FrameRecorder, TrafficLog
from .perform import Performer
from .timing import Timing

T = TypeVar("T")


def drive(
    procedure: Procedure[T],
    transport: Transport,
    listeners: FrameRecorder | Sequence[FrameRecorder] | None = None,
    on_note: Callable[[Any], None] | None = None,
    timeout: float | None = None,
) -> T:
    """Carry out a procedure's actions on a transport until it returns (docs/drivers.md).

    An error performing an action (a port that fails, an interrupt) is thrown into the
    procedure at the action that failed, so its `except`/`finally` can restore the bus; when
    `timeout` seconds have passed, CallTimeout is thrown in at the next blocking action. A
    procedure this driver leaves unfinished is closed.
    """
    if listeners is None:
        listeners = ()
    elif not isinstance(listeners, Sequence):
        listeners = (listeners,)
    performer = Performer(transport, listeners, on_note)
    call_deadline = None if timeout is None else time.monotonic() + timeout
    result: Any = None
    error: BaseException | None = None
    try:
        while True:
            try:
                action: Action = procedure.send(result) if error is None else procedure.throw(error)
            except StopIteration as stop:
                return stop.value  # type: ignore[no-any-return]
            result, error = None, None
            try:
                blocking = type(action) in (Receive, Wait, WaitUntil)
                if blocking and call_deadline is not None and time.monotonic() >= call_deadline:
                    call_deadline = None  # thrown once; the procedure's cleanup may still use the bus
                    raise CallTimeout(f"the bus call took longer than {timeout:g} s and was abandoned")
                result = _perform(performer, transport, action, call_deadline)
            except BaseException as err:  # every failure goes to the procedure (docs/drivers.md)
                error = err
    finally:
        procedure.close()


def _perform(performer: Performer, transport: Transport, action: Action, call_deadline: float | None) -> Any:
    if type(action) is Receive:
        until = action.until if call_deadline is None else min(action.until, call_deadline)
        wait = performer.read_timeout(until)
        return b"" if wait is None else performer.received(transport.read(action.max_bytes, wait))
    if type(action) is Wait:
        seconds = action.seconds if call_deadline is None else min(action.seconds, call_deadline - time.monotonic())
        if seconds > 0:
            time.sleep(seconds)
        return None
    if type(action) is WaitUntil:
        when = action.when if call_deadline is None else min(action.when, call_deadline)
        delay = when - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        return time.monotonic()
    return performer.perform(action)


class Listeners:
    """The bus's listeners (python-can style): every byte sent and received goes to each."""

    def __init__(self, log_path: str | None, tracer: FrameRecorder | None, more: Sequence[FrameRecorder]) -> None:
        self.items: list[FrameRecorder] = list(more)
        if tracer is not None:
            self.items.append(tracer)
        if log_path:
            self.items.append(TrafficLog(log_path))

    def close(self) -> None:
        for listener in self.items:
            listener.close()


def make_core(transport: Transport, retries: int, timing: Timing | None, options: dict[str, Any]) -> BusCore:
    """The BusCore both buses build from their keyword options (see Bus)."""
    core = BusCore(baudrate=transport.baudrate, retries=retries, timing=timing or Timing(latency=transport.latency))
    if "busy_window" in options:
        core.busy_window = options.pop("busy_window")
    core.busy_windows.update(options.pop("busy_windows", None) or {})
    if "late_answer" in options:
        core.late_answer = options.pop("late_answer")
    if "retry_pause" in options:
        core.retry_pause = options.pop("retry_pause")
    if options:
        raise TypeError(f"unknown bus option(s): {', '.join(sorted(options))}")
    return core


class Bus:
    """A bus of controllers behind one port. Thread-safe: one procedure at a time.

    with Bus.open("/dev/ttyUSB0", baudrate=115200) as bus:
        print(bus.motor(1).read_state())

    Options: retries, timing, busy_window (s, every ID), busy_windows ({id: s}), late_answer (s),
    retry_pause (s); log_path (a traffic log), tracer and listeners (byte listeners, all kept).
    """

    def __init__(
        self,
        transport: Transport,
        retries: int = 2,
        timing: Timing | None = None,
        log_path: str | None = None,
        tracer: FrameRecorder | None = None,
        listeners: Sequence[FrameRecorder] = (),
        **options: Any,
    ) -> None:
        self.transport = transport
        self.core = make_core(transport, retries, timing, options)
        self._lock = threading.RLock()
        self._listeners = Listeners(log_path, tracer, listeners)

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> Bus:
        """Open a device path or port URL (socket://, rfc2217://, loop://, sim://...).

        Options: latency (s), rs485 (True, 'kernel', 'rts' or a nurimc.transport.RS485: direction
        control for adapters that do not switch themselves), and the constructor's."""
        latency, rs485 = options.pop("latency", None), options.pop("rs485", None)
        return cls(open_transport(url, baudrate, latency, rs485), **options)

    @property
    def listeners(self) -> list[FrameRecorder]:
        """Every byte listener (traffic log, tracer, ...); add or remove freely."""
        return self._listeners.items

    def add_listener(self, listener: FrameRecorder) -> None:
        with self._lock:
            self._listeners.items.append(listener)

    def remove_listener(self, listener: FrameRecorder) -> None:
        with self._lock:
            self._listeners.items.remove(listener)

    @property
    def baudrate(self) -> int:
        return self.core.baudrate

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        self.set_baudrate(rate)

    def set_baudrate(self, rate: int) -> None:
        """Switch the host's rate (as AsyncBus.set_baudrate; the property setter does the same)."""
        self.run(self.core.set_baud(rate))

    @property
    def stats(self) -> Any:
        return self.core.stats

    def run(
        self, procedure: Procedure[T], on_note: Callable[[Any], None] | None = None, timeout: float | None = None
    ) -> T:
        """Run any procedure (from core, motor, group, discovery, config) under the bus lock;
        `timeout`: seconds for the whole call, then CallTimeout (after the procedure's cleanup)."""
        with self._lock:
            return drive(procedure, self.transport, self._listeners.items, on_note, timeout)

    def request(self, request: Request, retries: int | None = None) -> Message:
        """Send a feedback request and return the checked answer (raises NoAnswer & co.)."""
        return self.run(self.core.ask(request, retries))

    def send(self, *commands: Command) -> None:
        """Send commands back to back without waiting for answers (they are never answered);
        an ID still busy writing its EEPROM is waited for first (docs/protocol.md)."""
        self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str | None = None) -> Motor:
        """A handle for one controller. Without `product`: the product line discovery found for the
        ID on this bus (nurimc.products), else MC."""
        return Motor(self, device_id, product or self.core.products.get(device_id, "mc"))

    def close(self) -> None:
        with self._lock:
            try:
                self.transport.close()
            finally:
                self._listeners.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
