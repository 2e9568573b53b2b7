"""The synchronous bus: runs core procedures on a transport, one thread at a time."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from .actions import Procedure, Receive, Wait
from .core import BusCore
from .log import FrameRecorder, TrafficLog
from .perform import Performer
from .timing import Timing

T = TypeVar("T")


def drive(
    procedure: Procedure[T],
    transport: Transport,
    log: FrameRecorder | None = None,
    on_note: Callable[[Any], None] | None = None,
) -> T:
    """Carry out a procedure's actions on a transport until it returns."""
    performer = Performer(transport, log, on_note)
    result: Any = None
    try:
        action = procedure.send(None)
        while True:
            if type(action) is Receive:
                remaining = performer.remaining(action.deadline)
                result = performer.received(transport.read(action.max_bytes, remaining)) if remaining > 0 else b""
            elif type(action) is Wait:
                time.sleep(action.seconds)
                result = None
            else:
                result = performer.perform(action)
            action = procedure.send(result)
    except StopIteration as stop:
        return stop.value  # type: ignore[no-any-return]


class Bus:
    """A bus of controllers behind one port. Thread-safe: one procedure at a time.

    with Bus.open("/dev/ttyUSB0", baudrate=115200) as bus:
        print(bus.motor(1).read_state())
    """

    def __init__(
        self,
        transport: Transport,
        retries: int = 2,
        timing: Timing | None = None,
        log_path: str | None = None,
        tracer: FrameRecorder | None = None,
    ) -> None:
        self.transport = transport
        self.core = BusCore(
            baudrate=transport.baudrate, retries=retries, timing=timing or Timing(latency=transport.latency)
        )
        self._lock = threading.RLock()
        # A tracer (e.g. the CLI's -v) sees the same bytes a traffic log would.
        self._log: FrameRecorder | None = tracer or (TrafficLog(log_path) if log_path else None)

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> Bus:
        """Open a device path or pyserial URL (socket://, rfc2217://, loop://, sim://...)."""
        latency = options.pop("latency", None)
        return cls(open_transport(url, baudrate, latency), **options)

    @property
    def baudrate(self) -> int:
        return self.core.baudrate

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        self.run(self.core.set_baud(rate))

    @property
    def stats(self) -> Any:
        return self.core.stats

    def run(self, procedure: Procedure[T], on_note: Callable[[Any], None] | None = None) -> T:
        """Run any procedure (from core, motor, group, discovery, config) under the bus lock."""
        with self._lock:
            return drive(procedure, self.transport, self._log, on_note)

    def request(self, request: Request, retries: int | None = None) -> Message:
        """Send a feedback request and return the checked answer (raises NoAnswer & co.)."""
        return self.run(self.core.ask(request, retries))

    def send(self, *commands: Command) -> None:
        """Send commands back to back without waiting (they are never answered)."""
        self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str = "mc") -> Motor:
        return Motor(self, device_id, product)

    def close(self) -> None:
        with self._lock:
            self.transport.close()
            if self._log:
                self._log.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


from ..motor import Motor  # noqa: E402 - Motor needs Bus for its type, Bus hands out Motors
