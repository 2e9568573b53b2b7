"""Reconnect (Bus.open(..., reconnect=True)): a port cut and restored by a proxy in front of the simulator."""

from __future__ import annotations

import asyncio
import os
import threading
from pathlib import Path

import pytest
import serial

from nurimc import Bus
from nurimc.drivers.aio import AsyncBus
from nurimc.errors import PortError, PortLost
from nurimc.protocol import BROADCAST_ID, SetControl
from nurimc.transport.reconnect import PortEvent, ReconnectingTransport, by_id_names, is_loss

from .outage import BAUD, cuttable_bus, frames_after_cut


class Events:
    def __init__(self) -> None:
        self.items: list[PortEvent] = []
        self.back = threading.Event()

    def __call__(self, event: PortEvent) -> None:
        self.items.append(event)
        if event.kind == "back":
            self.back.set()

    def kinds(self) -> list[str]:
        return [e.kind for e in self.items]


@pytest.mark.parametrize("kind", ["pty", "tcp"])
def test_a_cut_port_fails_fast_once_reported_and_serves_again_when_restored(kind: str, tmp_path: Path) -> None:
    with cuttable_bus(kind, tmp_path) as (_, proxy), Bus.open(proxy.url, BAUD, reconnect=True) as bus:
        transport = bus.transport
        assert isinstance(transport, ReconnectingTransport)
        events = Events()
        transport.watch(events)
        motor = bus.motor(1)
        motor.read_state()
        first_pty = os.path.realpath(proxy.url) if kind == "pty" else None
        proxy.cut()
        with pytest.raises(PortLost) as lost:
            for _ in range(5):  # the first call may still find bytes in flight; the loss shows within a few
                motor.read_state()
        assert "lost" in str(lost.value) and "reopened" in str(lost.value)
        assert isinstance(lost.value, PortError)  # old handlers of port errors still catch it
        for _ in range(20):  # while down: every call fails at once, the loss is reported once
            with pytest.raises(PortLost):
                motor.read_state()
        assert events.kinds() == ["lost"]
        assert not transport.up
        held = os.openpty()  # takes the freed pts number: the adapter comes back under another name
        try:
            proxy.restore()
            assert events.back.wait(10)
        finally:
            for fd in held:
                os.close(fd)
        assert events.kinds() == ["lost", "back"]
        assert "back after" in events.items[1].text
        assert motor.read_state().id == 1
        if kind == "pty":  # the link now points to another pseudo-terminal: the reopen followed it
            assert os.path.realpath(proxy.url) != first_pty


def test_frames_registered_while_down_are_the_first_sent_on_return(tmp_path: Path) -> None:
    with cuttable_bus("pty", tmp_path, ids=(1, 2)) as (sim, proxy), Bus.open(proxy.url, BAUD, reconnect=True) as bus:
        transport = bus.transport
        assert isinstance(transport, ReconnectingTransport)
        events = Events()
        transport.watch(events)
        bus.motor(1).run(30)
        assert sim.controllers[0].settings.control == 0
        proxy.cut()
        with pytest.raises(PortLost):
            for _ in range(5):
                bus.send(SetControl(BROADCAST_ID, 1))
        transport.on_return("estop", SetControl(BROADCAST_ID, 1).encode())
        proxy.restore()
        assert events.back.wait(10)
        assert events.items[-1].sent_first == ("estop",)
        assert transport.pending_on_return == {}
        bus.motor(1).read_state()  # then the traffic of the bus goes on
        sent = frames_after_cut(proxy)
        assert sent[0] == SetControl(BROADCAST_ID, 1)
        assert bus.motor(1).get("control") == "off"


def test_a_withdrawn_frame_is_not_sent(tmp_path: Path) -> None:
    with cuttable_bus("tcp", tmp_path) as (_, proxy), Bus.open(proxy.url, BAUD, reconnect=True) as bus:
        transport = bus.transport
        assert isinstance(transport, ReconnectingTransport)
        proxy.cut()
        with pytest.raises(PortLost):
            for _ in range(5):
                bus.motor(1).read_state()
        transport.on_return("stop", SetControl(1, 1).encode())
        transport.on_return("stop", None)
        proxy.restore()
        assert transport.wait_up(10)
        bus.motor(1).read_state()
        assert SetControl(1, 1) not in frames_after_cut(proxy)


def test_reopening_backs_off_instead_of_spinning() -> None:
    attempts: list[int] = []
    gate = threading.Event()

    class Port:
        url, latency = "fake", 0.0
        baudrate = 9600

        def __init__(self, fail: bool) -> None:
            self.fail = fail

        def write(self, data: bytes) -> None:
            if self.fail:
                raise PortError("cannot use port fake: gone") from OSError(5, "Input/output error")

        def read(self, max_bytes: int, timeout: float) -> bytes:
            return b""

        def discard_input(self) -> bytes:
            return b""

        def close(self) -> None:
            pass

    first = Port(fail=True)

    def opener(path: str, rate: int) -> Port:
        if not attempts:
            attempts.append(rate)
            return first
        attempts.append(rate)
        if not gate.is_set():
            raise PortError(f"port {path} not found")
        return Port(fail=False)

    transport = ReconnectingTransport("fake", opener, 9600, backoff=(0.01, 0.08))
    with pytest.raises(PortLost):
        transport.write(b"x")
    transport.baudrate = 57600  # kept while down, used for the reopen
    threading.Event().wait(0.5)
    tries = len(attempts) - 1
    assert 3 <= tries <= 12  # 0.01, 0.02, 0.04, 0.08, 0.08...: not thousands
    assert "not found" in transport.last_attempt_error
    gate.set()
    assert transport.wait_up(2)
    assert attempts[-1] == 57600
    transport.write(b"x")
    transport.close()


def test_closing_while_down_ends_the_reconnect_thread(tmp_path: Path) -> None:
    with cuttable_bus("pty", tmp_path) as (_, proxy):
        bus = Bus.open(proxy.url, BAUD, reconnect=True)
        proxy.cut()
        with pytest.raises(PortLost):
            for _ in range(5):
                bus.motor(1).read_state()
        bus.close()
        assert not [t for t in threading.enumerate() if t.name == "nurimc-reconnect"]
        with pytest.raises(PortError, match="closed"):
            bus.motor(1).read_state()


def test_without_reconnect_a_lost_port_stays_a_port_error(tmp_path: Path) -> None:
    with cuttable_bus("pty", tmp_path) as (_, proxy), Bus.open(proxy.url, BAUD) as bus:
        proxy.cut()
        with pytest.raises(PortError) as failure:
            bus.motor(1).read_state()
        assert not isinstance(failure.value, PortLost)


def test_the_async_bus_reconnects_too(tmp_path: Path) -> None:
    async def main(url: str, proxy: object) -> None:
        async with AsyncBus.open(url, BAUD, reconnect=True) as bus:
            transport = bus.transport
            assert isinstance(transport, ReconnectingTransport)
            await bus.motor(1).read_state()
            proxy.cut()  # type: ignore[attr-defined]
            with pytest.raises(PortLost):
                for _ in range(5):
                    await bus.motor(1).read_state()
            proxy.restore()  # type: ignore[attr-defined]
            assert await asyncio.to_thread(transport.wait_up, 10)
            assert (await bus.motor(1).read_state()).id == 1

    with cuttable_bus("tcp", tmp_path) as (_, proxy):
        asyncio.run(main(proxy.url, proxy))


def test_by_id_names_are_found_for_a_device(tmp_path: Path) -> None:
    device = tmp_path / "ttyUSB3"
    device.write_text("")
    by_id = tmp_path / "by-id"
    by_id.mkdir()
    (by_id / "usb-FTDI_FT232R_A1-if00-port0").symlink_to(device)
    (by_id / "usb-other").symlink_to(tmp_path / "ttyUSB4")
    assert by_id_names(str(device), by_id) == [str(by_id / "usb-FTDI_FT232R_A1-if00-port0")]
    assert by_id_names("socket://127.0.0.1:1", by_id) == []


@pytest.mark.parametrize(
    ("cause", "lost"),
    [
        (OSError(5, "Input/output error"), True),
        (OSError(6, "No such device or address"), True),
        (OSError(32, "Broken pipe"), True),
        (OSError(2, "No such file or directory"), True),
        (ConnectionResetError(104, "Connection reset by peer"), True),
        (serial.SerialException("device reports readiness to read but returned no data"), True),
        (ValueError("Invalid baud rate: 123"), False),
        (OSError(22, "Invalid argument"), False),
    ],
)
def test_which_failures_mean_the_port_is_gone(cause: Exception, lost: bool) -> None:
    try:
        raise PortError(f"cannot use port x: {cause}") from cause
    except PortError as error:
        assert is_loss(error) is lost
