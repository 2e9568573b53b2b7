"""RS485 direction control for adapters that do not switch between sending and receiving
themselves (a Raspberry Pi UART with a MAX485, many TTL-RS485 boards): the driver enable (DE)
line is wired to RTS and must be high only while the host sends.

Two ways, tried in this order with `mode="auto"`:
- kernel: the serial driver switches RTS itself (Linux TIOCSRS485, pyserial's `rs485_mode`);
  exact timing, nothing for us to do per write.
- rts: the library raises RTS, writes, waits until the last stop bit has left (computed from
  the baud rate and frame format), then drops RTS. Costs the frame's wire time per write.
A port with neither (a pseudo-terminal, a socket) is a clear PortError, never a silent no-op.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from ..errors import PortError

Mode = Literal["auto", "kernel", "rts"]
MODES: tuple[Mode, ...] = ("auto", "kernel", "rts")


@dataclass(frozen=True)
class RS485:
    """How to drive the direction line.

    rts_level_for_tx: RTS state while sending (True = asserted, as pyserial). Which level raises
        DE depends on the driver and board (an asserted RTS is a low pin on a TTL UART); False
        is `--rs485-invert`.
    delay_before_tx: seconds between raising DE and the first start bit (most transceivers: 0).
    delay_after_tx: extra seconds DE stays up after the last stop bit.
    """

    mode: Mode = "auto"
    rts_level_for_tx: bool = True
    delay_before_tx: float = 0.0
    delay_after_tx: float = 0.0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"rs485 mode {self.mode!r}: use one of {', '.join(MODES)}")
        for name in ("delay_before_tx", "delay_after_tx"):
            value = getattr(self, name)
            if not 0 <= value <= 1:
                raise ValueError(f"rs485 {name}={value}: give seconds between 0 and 1")


def rs485_options(value: bool | str | RS485 | None) -> RS485 | None:
    """Normalise `Bus.open(..., rs485=...)`: True/'auto', 'kernel', 'rts', an RS485, or None/False."""
    if value is None or value is False:
        return None
    if value is True:
        return RS485()
    if isinstance(value, RS485):
        return value
    if isinstance(value, str):
        return RS485(mode=value)  # type: ignore[arg-type]  # checked in __post_init__
    raise TypeError(f"rs485={value!r}: give True, 'auto', 'kernel', 'rts' or an RS485(...)")


def bits_per_byte(port: Any) -> int:
    """Start bit + data bits + parity bit + stop bits of the port's frame format (8N1: 10)."""
    data = int(getattr(port, "bytesize", 8))
    parity = 0 if str(getattr(port, "parity", "N")) == "N" else 1
    stop = float(getattr(port, "stopbits", 1))
    return 1 + data + parity + (2 if stop > 1 else 1)


def wire_time(port: Any, size: int) -> float:
    """Seconds `size` bytes take on the wire at the port's baud rate."""
    return size * bits_per_byte(port) / float(port.baudrate)


class RtsDirection:
    """Toggles RTS around each write (the fallback when the kernel cannot)."""

    def __init__(
        self,
        options: RS485,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.options = options
        self.clock = clock
        self.sleep = sleep

    def receive(self, port: Any) -> None:
        port.rts = not self.options.rts_level_for_tx

    def write(self, port: Any, data: bytes) -> None:
        port.rts = self.options.rts_level_for_tx
        try:
            if self.options.delay_before_tx:
                self.sleep(self.options.delay_before_tx)
            started = self.clock()
            port.write(data)
            port.flush()  # the driver's buffer is empty; the UART may still be shifting bits out
            remaining = started + wire_time(port, len(data)) + self.options.delay_after_tx - self.clock()
            if remaining > 0:
                self.sleep(remaining)
        finally:
            self.receive(port)  # never leave the driver enabled: it would block every answer


def enable_rs485(port: Any, options: RS485, url: str) -> RtsDirection | None:
    """Switch the open port to RS485 direction control. Returns the per-write RTS toggler, or
    None when the kernel does it. Raises PortError when the port can do neither."""
    kernel_error: Exception | None = None
    if options.mode in ("auto", "kernel"):
        try:
            import serial.rs485

            port.rs485_mode = serial.rs485.RS485Settings(
                rts_level_for_tx=options.rts_level_for_tx,
                rts_level_for_rx=not options.rts_level_for_tx,
                delay_before_tx=options.delay_before_tx,
                delay_before_rx=options.delay_after_tx,
            )
            return None
        except (ValueError, OSError, NotImplementedError, AttributeError) as error:
            kernel_error = error
            _forget_rs485_mode(port)
        if options.mode == "kernel":
            raise PortError(f"{url}: the driver has no kernel RS485 mode ({kernel_error}); try --rs485 with mode rts")
    direction = RtsDirection(options)
    try:
        direction.receive(port)
    except (ValueError, OSError, NotImplementedError, AttributeError) as error:
        tried = f"kernel RS485 mode: {kernel_error}; " if kernel_error else ""
        raise PortError(
            f"{url}: cannot control the RS485 direction ({tried}RTS: {error}); a pseudo-terminal or network "
            "port has no direction line: use the adapter's serial device, or drop --rs485 if it switches itself"
        ) from error
    return direction


def _forget_rs485_mode(port: Any) -> None:
    """pyserial keeps a refused rs485_mode and would retry it on every reconfiguration (baud change)."""
    try:
        port.rs485_mode = None
    except (ValueError, OSError, NotImplementedError, AttributeError):
        if hasattr(port, "_rs485_mode"):
            port._rs485_mode = None
