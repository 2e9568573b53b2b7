"""`--rs485` / `--rs485-invert` / NURIMC_RS485 and `Bus.open(..., rs485=...)` against a fake serial
device: a simulated bus behind a port with an RTS line (and, on request, the kernel's RS485 mode),
opened where pyserial would open /dev/ttyAMA0."""

from __future__ import annotations

from typing import Any

import pytest
import serial

from nurimc import Bus
from nurimc.sim import SimBus
from nurimc.transport import RS485

from .inprocess import assert_clean, nurimc

DEVICE = "/dev/ttyFAKE485"


class FakeDevice:
    """A serial device whose writes record the RTS level; with kernel=True it takes pyserial's
    rs485_mode (Linux TIOCSRS485), otherwise it refuses it as a UART without the ioctl does."""

    OWN = frozenset({"port", "kernel", "rts", "rts_at_write", "rts_changes", "_rs485"})

    def __init__(self, port: Any, kernel: bool) -> None:
        self.port, self.kernel = port, kernel
        self.rts = True  # pyserial asserts RTS on open
        self.rts_at_write: list[bool] = []
        self.rts_changes = 0
        self._rs485: Any = None

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(getattr(type(self), name, None), property):
            object.__setattr__(self, name, value)  # rs485_mode: the setter below
        elif name in FakeDevice.OWN:
            if name == "rts":
                self.__dict__["rts_changes"] = self.__dict__.get("rts_changes", -1) + 1
            self.__dict__[name] = value
        else:
            setattr(self.port, name, value)  # baudrate, timeout: the simulated port's

    def __getattr__(self, name: str) -> Any:
        return getattr(self.port, name)

    @property
    def rs485_mode(self) -> Any:
        return self._rs485

    @rs485_mode.setter
    def rs485_mode(self, settings: Any) -> None:
        if settings is not None and not self.kernel:
            raise ValueError("Failed to set RS485 mode: [Errno 25] Inappropriate ioctl for device")
        self.__dict__["_rs485"] = settings

    def write(self, data: bytes) -> int:
        self.rts_at_write.append(self.rts)
        return int(self.port.write(data))


@pytest.fixture
def device(monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest) -> Any:
    """The fake device; `kernel` from the test's parameter (default: RTS only)."""
    kernel = getattr(request, "param", False)
    sim = SimBus()
    sim.add_controller(id=1, baud=9600)
    opened: list[FakeDevice] = []
    real = serial.serial_for_url

    def serial_for_url(url: str, **options: Any) -> Any:
        if url != DEVICE:
            return real(url, **options)
        assert options.get("exclusive") is True  # a device path is opened exclusively
        fake = FakeDevice(sim.open_serial(baudrate=options["baudrate"]), kernel)
        opened.append(fake)
        return fake

    monkeypatch.setattr(serial, "serial_for_url", serial_for_url)
    monkeypatch.delenv("NURIMC_RS485", raising=False)
    yield opened
    sim.close()


def test_without_rs485_rts_is_left_alone(device: list[FakeDevice]) -> None:
    result = nurimc("--port", DEVICE, "--id", "1", "ping")
    assert_clean(result)
    assert result.code == 0 and device[0].rts_changes == 0 and device[0].rs485_mode is None


@pytest.mark.parametrize("how", [["--rs485"], ["--rs485", "--rs485-invert"], ["--rs485-invert"], ["env"]])
def test_rts_is_the_driver_enable_while_sending(
    device: list[FakeDevice], how: list[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    if how == ["env"]:
        monkeypatch.setenv("NURIMC_RS485", "1")
        how = []
    sending = "--rs485-invert" not in how  # --rs485-invert: RTS low while sending
    result = nurimc("--port", DEVICE, *how, "--id", "1", "get", "rated-speed")
    assert_clean(result)
    assert result.code == 0 and "3000" in result.out, result.err
    port = device[0]
    assert port.rts_at_write and all(level is sending for level in port.rts_at_write)
    assert port.rts is (not sending)  # receiving between frames: the answers got through
    assert port.rts_changes >= 2 * len(port.rts_at_write)


@pytest.mark.parametrize("device", [True], indirect=True)
def test_the_kernel_does_it_when_it_can(device: list[FakeDevice]) -> None:
    result = nurimc("--port", DEVICE, "--rs485-invert", "--id", "1", "ping")
    assert_clean(result)
    assert result.code == 0
    settings = device[0].rs485_mode
    assert settings is not None and settings.rts_level_for_tx is False and settings.rts_level_for_rx is True
    assert device[0].rts_changes == 0  # the driver switches; we never toggle per write


def test_a_port_without_rts_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    for port in ("sim://?ids=1,", "socket://127.0.0.1:9"):
        result = nurimc("--port", port, "--rs485", "--id", "1", "ping")
        assert_clean(result)
        assert result.code == 1 and "has no RTS line" in result.err


@pytest.mark.parametrize("option", [True, "rts", "auto", RS485(rts_level_for_tx=False)])
def test_bus_open_takes_rs485(device: list[FakeDevice], option: bool | str | RS485) -> None:
    with Bus.open(DEVICE, baudrate=9600, rs485=option) as bus:
        assert bus.motor(1).ping()
    level = not (isinstance(option, RS485) and not option.rts_level_for_tx)
    assert device[0].rts_at_write and all(x is level for x in device[0].rts_at_write)


def test_bus_open_refuses_a_kernel_mode_the_port_lacks(device: list[FakeDevice]) -> None:
    from nurimc import PortError

    with pytest.raises(PortError, match="RS485") as caught:
        Bus.open(DEVICE, baudrate=9600, rs485="kernel")
    assert "\n" not in str(caught.value)
