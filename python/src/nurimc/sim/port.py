"""An in-process serial port on a SimBus that behaves like a pyserial Serial."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import serial
from serial.serialutil import PortNotOpenError, SerialBase

from .core import HostLink, WireModel

if TYPE_CHECKING:
    from _typeshed import ReadableBuffer


class SimSerial(SerialBase):
    """pyserial-compatible: read/write/read_until/in_waiting/reset_*_buffer/flush/close.

    Setting `baudrate` changes the rate the bus model sees from this host.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.bus: WireModel | None = None
        self.link: HostLink | None = None
        self._own_bus = False
        self.monitor = False  # hear every host's bytes too (a second adapter on the line)
        super().__init__(*args, **kwargs)

    @classmethod
    def on_bus(
        cls, bus: WireModel, baudrate: int = 9600, timeout: float | None = 0.1, monitor: bool = False
    ) -> SimSerial:
        port = cls(None, baudrate=baudrate, timeout=timeout)
        port.bus = bus
        port.monitor = monitor
        port.port = "sim"
        port.open()
        return port

    # --- SerialBase hooks ---------------------------------------------------------------------
    def open(self) -> None:
        if self.is_open:
            raise serial.SerialException("port already open")
        if self.bus is None:
            raise serial.SerialException("SimSerial needs a bus: use SimBus.open_serial() or a sim:// URL")
        self.link = self.bus.open_link(int(self.baudrate), monitor=self.monitor)
        self.is_open = True

    def close(self) -> None:
        if self.link is not None:
            self.link.close()
            self.link = None
        if self._own_bus and self.bus is not None:
            self.bus.close()
        self.is_open = False

    def _reconfigure_port(self) -> None:
        if self.link is not None:
            self.link.baud = int(self.baudrate)

    # --- I/O --------------------------------------------------------------------------------------
    def _require_link(self) -> HostLink:
        if not self.is_open or self.link is None:
            raise PortNotOpenError()
        return self.link

    @property
    def in_waiting(self) -> int:
        link = self._require_link()
        with link.bus.lock:
            link.bus.pump()
            return len(link.rx)

    def read(self, size: int = 1) -> bytes:
        link = self._require_link()
        bus = link.bus
        out = bytearray()
        if bus.virtual is not None:
            return self._read_virtual(link, size)
        deadline = None if self.timeout is None else time.monotonic() + self.timeout
        with bus.changed:
            while True:
                bus.pump()
                if link.rx and len(out) < size:
                    n = min(size - len(out), len(link.rx))
                    out += link.rx[:n]
                    del link.rx[:n]
                if len(out) >= size or not self.is_open:
                    break
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    break
                wait = bus.wait_hint()
                bus.changed.wait(wait if remaining is None else min(wait, remaining))
        return bytes(out)

    def _read_virtual(self, link: HostLink, size: int) -> bytes:
        """On virtual time: wait by moving the clock, never by sleeping."""
        bus = link.bus
        out = bytearray()
        with bus.lock:
            deadline = None if self.timeout is None else bus.now() + self.timeout
            while True:
                bus.pump()
                if link.rx and len(out) < size:
                    n = min(size - len(out), len(link.rx))
                    out += link.rx[:n]
                    del link.rx[:n]
                if len(out) >= size or not self.is_open or not bus.wait_virtually(deadline):
                    break
        return bytes(out)

    def write(self, b: ReadableBuffer, /) -> int:
        link = self._require_link()
        raw = bytes(b)
        link.write(raw)
        return len(raw)

    def flush(self) -> None:
        self._require_link()

    def reset_input_buffer(self) -> None:
        link = self._require_link()
        with link.bus.lock:
            link.bus.pump()
            link.rx.clear()

    def reset_output_buffer(self) -> None:
        self._require_link()  # writes reach the bus at once: nothing is ever waiting to go out

    @property
    def out_waiting(self) -> int:
        return 0

    def cancel_read(self) -> None:
        pass

    def _update_rts_state(self) -> None:
        pass

    def _update_dtr_state(self) -> None:
        pass

    def _update_break_state(self) -> None:
        pass
