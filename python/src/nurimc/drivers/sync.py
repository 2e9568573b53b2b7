"""The synchronous bus: runs core procedures on a transport, one thread at a time."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from typing import Any, TypeVar

from ..core.actions import Procedure
from ..core.clock import REAL_CLOCK, Clock
from ..core.timing import Timing
from ..procedures.motor import Motor
from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from ..transport.trafficlog import FrameRecorder
from . import fastpath
from .options import Listeners, make_core
from .perform import Performer, run_in_place

T = TypeVar("T")


def drive(
    procedure: Procedure[T],
    transport: Transport,
    listeners: FrameRecorder | Sequence[FrameRecorder] | None = None,
    on_note: Callable[[Any], None] | None = None,
    timeout: float | None = None,
    clock: Clock | None = None,
) -> T:
    """Carry out a procedure's actions on a transport until it returns (docs/drivers.md).

    The trampoline (`perform.run_in_place`: `perform.steps` for a driver that blocks in place)
    does the stepping, the error routing and the call timeout; this driver only blocks: reads
    on the transport, sleeps on `clock` (default: the real one)."""
    if listeners is None:
        listeners = ()
    elif type(listeners) is not list and not isinstance(listeners, Sequence):  # a list: no ABC check
        listeners = (listeners,)
    performer = Performer(transport, listeners, on_note, clock)
    return run_in_place(procedure, performer, timeout, transport.read, performer.clock.sleep)


class Bus:
    """A bus of controllers behind one port. Thread-safe: one procedure at a time.

    with Bus.open("/dev/ttyUSB0", baudrate=115200) as bus:
        print(bus.motor(1).read_state())

    Options: retries, timing, busy_window (s, every ID), busy_windows ({id: s}), late_answer (s),
    retry_pause (s); log_path (a traffic log), tracer and listeners (byte listeners, all kept);
    clock (default: the real one; a VirtualClock shared with a SimBus runs on virtual time).
    """

    def __init__(
        self,
        transport: Transport,
        retries: int = 2,
        timing: Timing | None = None,
        log_path: str | None = None,
        tracer: FrameRecorder | None = None,
        listeners: Sequence[FrameRecorder] = (),
        clock: Clock | None = None,
        **options: Any,
    ) -> None:
        self.transport = transport
        self.clock: Clock = clock or REAL_CLOCK
        self.core = make_core(transport, retries, timing, options)
        self._lock = threading.RLock()
        self._listeners = Listeners(log_path, tracer, listeners)
        #: the fast path for single requests (drivers/fastpath.py; NURIMC_NO_FAST_PATH=1: off)
        self._fast_path = fastpath.enabled()

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> Bus:
        """Open a device path or port URL (socket://, rfc2217://, loop://, sim://...).

        Options: latency (s), rs485 (True, 'kernel', 'rts' or a nurimc.transport.RS485: direction
        control for adapters that do not switch themselves), reconnect (True: reopen the port when
        it goes away; calls fail fast with PortLost meanwhile: docs/library.md), and the constructor's."""
        latency, rs485 = options.pop("latency", None), options.pop("rs485", None)
        return cls(open_transport(url, baudrate, latency, rs485, options.pop("reconnect", False)), **options)

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
            return drive(procedure, self.transport, self._listeners.items, on_note, timeout, self.clock)

    def request(self, request: Request, retries: int | None = None) -> Message:
        """Send a feedback request and return the checked answer (raises NoAnswer & co.)."""
        with self._lock:
            if self._fast_path and not self._listeners.items:
                return fastpath.ask(self.core, self.transport, self.clock, request, retries)
            return self.run(self.core.ask(request, retries))  # run(): what a subclass does around it too

    def _request_then(self, request: Request, then: Callable[[Message], T]) -> T:
        """`then(request(request))` under the bus lock: what a handle's one-request calls
        (get) run, through the fast path when it applies (docs/performance.md)."""
        with self._lock:
            if self._fast_path and not self._listeners.items:  # request(), inline
                return then(fastpath.ask(self.core, self.transport, self.clock, request))
            return then(self.request(request))

    def _read_then(self, request: Request, then: Callable[[Message, float], T]) -> T:
        """`then(answer, when it was read)` under the bus lock: read_state's request and reading,
        as its procedure (ask, then Now), through the fast path when it applies."""
        with self._lock:
            if self._fast_path and not self._listeners.items:  # request(), inline: every reading comes here
                answer = fastpath.ask(self.core, self.transport, self.clock, request)
            else:
                answer = self.request(request)
            return then(answer, self.clock.now())

    def _request_each(
        self, asks: Iterable[tuple[Request, Callable[[Message, float], T]]], caught: tuple[type[Exception], ...]
    ) -> list[T | Exception]:
        """`_read_then` for each pair in turn under one hold of the bus lock; an error of a
        `caught` class takes its request's place in the list (a group's reads)."""
        out: list[T | Exception] = []
        with self._lock:
            for request, then in asks:
                try:
                    out.append(self._read_then(request, then))
                except caught as err:
                    out.append(err)
        return out

    def send(self, *commands: Command) -> None:
        """Send commands back to back without waiting for answers (they are never answered);
        an ID still busy writing its EEPROM is waited for first (docs/protocol.md)."""
        self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str | None = None) -> Motor:
        """A handle for one controller. Without `product`: the product line discovery found for the
        ID on this bus (nurimc.procedures.products), else MC."""
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
