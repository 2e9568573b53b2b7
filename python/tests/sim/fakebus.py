"""A bus on a fake clock: physics tests move time themselves and never sleep."""

from __future__ import annotations

from typing import Any

from nurimc.core.clock import VirtualClock
from nurimc.sim import SimBus

TURNAROUND = 0.005  # s the fake clock moves after each write: time for an answer to arrive


class FakePort:
    """Enough of a serial port for wirehelp: every write moves the clock by TURNAROUND, so the
    answer is there when read (reads never wait)."""

    def __init__(self, bus: SimBus, clock: VirtualClock, baud: int = 9600) -> None:
        self.bus = bus
        self.clock = clock
        self.inner = bus.open_serial(baudrate=baud, timeout=0)
        self.timeout: float | None = 0.0

    def write(self, data: bytes) -> int:
        self.inner.write(data)
        self.sleep(TURNAROUND)
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return self.inner.read(size)

    def reset_input_buffer(self) -> None:
        self.inner.reset_input_buffer()

    def sleep(self, seconds: float) -> None:
        """Let `seconds` pass on the bus (physics stepped)."""
        self.clock.advance(seconds)  # the bus follows its clock: physics stepped

    @property
    def baudrate(self) -> int:
        return int(self.inner.baudrate)

    @baudrate.setter
    def baudrate(self, value: int) -> None:
        self.inner.baudrate = value

    def close(self) -> None:
        self.inner.close()


def fake_bus(controllers: int | list[int] = 1, product: str = "mc", **bus_args: Any) -> tuple[SimBus, FakePort]:
    clock = VirtualClock()
    bus_args.setdefault("eeprom_time", 0.0)
    bus = SimBus(clock=clock, **bus_args)
    ids = list(range(controllers)) if isinstance(controllers, int) else controllers
    for i in ids:
        bus.add_controller(i, 9600, product)
    return bus, FakePort(bus, clock)
