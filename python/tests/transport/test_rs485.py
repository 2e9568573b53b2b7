"""RS485 direction control against fake ports (and a real pseudo-terminal, which has neither way)."""

from __future__ import annotations

import os
import pty
from collections.abc import Iterator
from typing import Any

import pytest

from nurimc import Bus, PortError
from nurimc.sim import SimBus
from nurimc.transport import RS485, SerialTransport, open_transport
from nurimc.transport.rs485 import RtsDirection, bits_per_byte, enable_rs485, rs485_options, wire_time

PING_1 = bytes.fromhex("fffe01025ca0")


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


class FakePort:
    """Records RTS changes and writes; refuses the kernel's RS485 mode and/or RTS on request."""

    def __init__(self, kernel: bool, rts: bool, clock: FakeClock | None = None, baudrate: int = 9600) -> None:
        self.kernel, self.rts_ok, self.clock = kernel, rts, clock
        self.baudrate, self.bytesize, self.parity, self.stopbits = baudrate, 8, "N", 1
        self.events: list[tuple[str, Any]] = []
        self._rs485_mode: Any = None
        self._rts = True  # pyserial asserts RTS on open
        self.write_takes = 0.001
        self.fail_write = False
        self.closed = False

    @property
    def rs485_mode(self) -> Any:
        return self._rs485_mode

    @rs485_mode.setter
    def rs485_mode(self, settings: Any) -> None:
        self._rs485_mode = settings  # as pyserial: stored first, then applied
        if settings is not None and not self.kernel:
            raise ValueError("Failed to set RS485 mode: [Errno 25] Inappropriate ioctl for device")

    @property
    def rts(self) -> bool:
        return self._rts

    @rts.setter
    def rts(self, level: bool) -> None:
        if not self.rts_ok:
            raise OSError(25, "Inappropriate ioctl for device")
        self._rts = level
        self.events.append(("rts", level))

    def write(self, data: bytes) -> int:
        if self.fail_write:
            raise OSError(5, "Input/output error")
        self.events.append(("write", (bytes(data), self._rts)))
        if self.clock:
            self.clock.now += self.write_takes
        return len(data)

    def flush(self) -> None:
        self.events.append(("flush", self._rts))

    def close(self) -> None:
        self.closed = True


def test_kernel_mode_is_preferred_and_carries_polarity_and_delays() -> None:
    port = FakePort(kernel=True, rts=True)
    options = RS485(rts_level_for_tx=False, delay_before_tx=0.002, delay_after_tx=0.001)
    assert enable_rs485(port, options, "/dev/ttyAMA0") is None  # the driver switches itself
    settings = port.rs485_mode
    assert (settings.rts_level_for_tx, settings.rts_level_for_rx) == (False, True)
    assert (settings.delay_before_tx, settings.delay_before_rx) == (0.002, 0.001)
    assert port.events == []  # the library never touches RTS in kernel mode


def test_without_kernel_support_rts_is_toggled_and_the_refused_mode_forgotten() -> None:
    port = FakePort(kernel=False, rts=True)
    direction = enable_rs485(port, RS485(), "/dev/ttyUSB0")
    assert isinstance(direction, RtsDirection)
    assert port.rs485_mode is None  # pyserial would retry it on every baud change otherwise
    assert port.events == [("rts", False)]  # receiving from the start


def test_rts_is_high_exactly_while_the_frame_is_on_the_wire() -> None:
    clock = FakeClock()
    port = FakePort(kernel=False, rts=True, clock=clock)
    direction = RtsDirection(RS485(mode="rts"), clock=clock, sleep=clock.sleep)
    direction.write(port, PING_1)
    assert port.events == [("rts", True), ("write", (PING_1, True)), ("flush", True), ("rts", False)]
    # 6 bytes x 10 bits at 9600 bps = 6.25 ms on the wire; the write itself took 1 ms of it
    assert clock.sleeps == [pytest.approx(0.00525)]


def test_delays_and_inverted_polarity() -> None:
    clock = FakeClock()
    port = FakePort(kernel=False, rts=True, clock=clock, baudrate=115200)
    port.write_takes = 0.0001
    options = RS485(mode="rts", rts_level_for_tx=False, delay_before_tx=0.0005, delay_after_tx=0.0002)
    RtsDirection(options, clock=clock, sleep=clock.sleep).write(port, PING_1)
    assert port.events[0] == ("rts", False) and port.events[-1] == ("rts", True)
    assert port.events[1] == ("write", (PING_1, False))
    assert clock.sleeps[0] == 0.0005
    assert clock.sleeps[1] == pytest.approx(60 / 115200 + 0.0002 - 0.0001)


def test_a_write_shorter_than_the_call_needs_no_wait() -> None:
    clock = FakeClock()
    port = FakePort(kernel=False, rts=True, clock=clock, baudrate=1_000_000)
    port.write_takes = 0.01  # far longer than 60 us on the wire
    RtsDirection(RS485(), clock=clock, sleep=clock.sleep).write(port, PING_1)
    assert clock.sleeps == [] and port.events[-1] == ("rts", False)


def test_a_failed_write_still_releases_the_bus() -> None:
    port = FakePort(kernel=False, rts=True)
    port.fail_write = True
    with pytest.raises(OSError):
        RtsDirection(RS485()).write(port, PING_1)
    assert port.events == [("rts", True), ("rts", False)]


def test_frame_format_sets_the_wire_time() -> None:
    port = FakePort(kernel=False, rts=True, baudrate=115200)
    assert bits_per_byte(port) == 10
    port.parity, port.stopbits = "E", 2
    assert bits_per_byte(port) == 12
    assert wire_time(port, 6) == pytest.approx(72 / 115200)


def test_neither_way_is_a_clear_error() -> None:
    with pytest.raises(PortError, match=r"cannot control the RS485 direction.*pseudo-terminal"):
        enable_rs485(FakePort(kernel=False, rts=False), RS485(), "/dev/pts/3")


def test_kernel_only_does_not_fall_back() -> None:
    port = FakePort(kernel=False, rts=True)
    with pytest.raises(PortError, match="no kernel RS485 mode"):
        enable_rs485(port, RS485(mode="kernel"), "/dev/ttyUSB0")
    assert port.events == []


def test_options_are_checked() -> None:
    assert rs485_options(None) is None and rs485_options(False) is None
    assert rs485_options(True) == RS485() and rs485_options("rts") == RS485(mode="rts")
    with pytest.raises(ValueError, match="use one of auto, kernel, rts"):
        rs485_options("rtss")
    with pytest.raises(ValueError, match="between 0 and 1"):
        RS485(delay_after_tx=-0.1)


@pytest.fixture
def pty_path() -> Iterator[str]:
    controller, device = pty.openpty()
    yield os.ttyname(device)
    os.close(controller)
    os.close(device)


@pytest.mark.parametrize("mode", [True, "kernel", "rts"])
def test_a_pseudo_terminal_has_neither(pty_path: str, mode: bool | str) -> None:
    with pytest.raises(PortError, match=r"RS485|RTS") as caught:
        open_transport(pty_path, rs485=mode)
    assert "\n" not in str(caught.value)
    open_transport(pty_path).close()  # the refused attempt closed the port: it opens again (exclusive)


def test_url_ports_are_refused() -> None:
    with pytest.raises(PortError, match="sim:// port has no RTS line"):
        Bus.open("sim://?ids=1,", rs485=True)


class RecordingSimPort:
    """A simulator port with an RTS line: records the line's level at every write."""

    def __init__(self, port: Any) -> None:
        self.port = port
        self.rts = True
        self.rts_at_write: list[bool] = []

    @property
    def rs485_mode(self) -> None:
        return None

    @rs485_mode.setter
    def rs485_mode(self, settings: Any) -> None:
        raise ValueError("Failed to set RS485 mode: not supported")

    def write(self, data: bytes) -> int:
        self.rts_at_write.append(self.rts)
        return int(self.port.write(data))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.port, name)


def test_a_bus_with_rts_direction_talks_to_controllers() -> None:
    sim = SimBus()
    sim.add_controller(id=1, baud=115200)
    port = RecordingSimPort(sim.open_serial(baudrate=115200))
    direction = enable_rs485(port, RS485(), "/dev/ttyAMA0")
    assert direction is not None and port.rts is False
    with Bus(SerialTransport(port, "/dev/ttyAMA0", latency=0.002, direction=direction)) as bus:
        assert bus.motor(1).ping()
        assert bus.motor(1).get("rated-speed") == 3000
    assert port.rts_at_write and all(port.rts_at_write) and port.rts is False
    sim.close()
