"""Adapters that refuse a rate (termios EINVAL on 250000, 76800, ... on some USB chips): a scan
skips that rate with one note naming the rate and the adapter and goes on; a baud change to it
is refused before anything is sent to the controller. Through the real SerialTransport, on a
simulated port that refuses chosen rates the way pyserial does."""

from __future__ import annotations

import errno
import termios
from typing import Any

import pytest

from nurimc import Bus
from nurimc.core.clock import VirtualClock
from nurimc.errors import PortError, RateRefused
from nurimc.procedures.config import change_baud
from nurimc.procedures.discovery import Found, RateSkipped, discover
from nurimc.sim import SimBus
from nurimc.sim.port import SimSerial
from nurimc.transport import SerialTransport

REFUSED = (250000, 76800)


class PickyPort(SimSerial):
    """A port whose driver refuses some rates: pyserial has already stored the rate when
    tcsetattr fails, as on Linux (termios.error, errno EINVAL)."""

    refused: tuple[int, ...] = REFUSED
    gone = False

    def _reconfigure_port(self, *args: Any, **kwargs: Any) -> None:
        if self.gone:
            raise OSError(errno.EIO, "Input/output error")
        if int(self.baudrate) in self.refused:
            raise termios.error(errno.EINVAL, "Invalid argument")
        super()._reconfigure_port()


def picky_bus(sim: SimBus, clock: VirtualClock) -> tuple[Bus, PickyPort]:
    port = PickyPort(None, baudrate=9600, timeout=0.1)
    port.bus, port.port = sim, "sim"
    port.open()
    return Bus(SerialTransport(port, "/dev/ttyUSB7", latency=0.0), clock=clock, busy_window=0.05), port


def test_a_scan_skips_refused_rates_with_one_note_each_and_finds_the_rest() -> None:
    clock = VirtualClock()
    sim = SimBus(clock=clock, eeprom_time=0.02)
    sim.add_controller(id=3, baud=9600)
    sim.add_controller(id=8, baud=57600)
    bus, port = picky_bus(sim, clock)
    notes: list[object] = []
    found = bus.run(discover(bus.core), on_note=notes.append)
    assert [(f.id, f.baudrate) for f in found] == [(3, 9600), (8, 57600)]
    skipped = [n for n in notes if isinstance(n, RateSkipped)]
    assert [n.rate for n in skipped] == [250000, 76800]  # one note per refused rate, in scan order
    for note in skipped:
        assert str(note.rate) in note.reason and "/dev/ttyUSB7" in note.reason
    assert bus.baudrate == 9600 and int(port.baudrate) == 9600  # back where it started
    assert all(isinstance(f, Found) for f in found)
    sim.close()


def test_a_baud_change_to_a_refused_rate_sends_nothing_and_keeps_the_controller() -> None:
    clock = VirtualClock()
    sim = SimBus(clock=clock, eeprom_time=0.02)
    controller = sim.add_controller(id=3, baud=9600)
    bus, port = picky_bus(sim, clock)
    written: list[bytes] = []
    write = port.write
    port.write = lambda data: written.append(bytes(data)) or write(data)  # type: ignore[method-assign,func-returns-value]
    with pytest.raises(RateRefused, match=r"cannot be set to 250000 bps.*ID 3 was not changed"):
        bus.run(change_baud(bus.core, 3, 250000))
    assert written == []  # refused before anything was sent
    assert controller.baud == 9600 and bus.baudrate == 9600 and int(port.baudrate) == 9600
    assert bus.motor(3).ping()
    assert bus.run(change_baud(bus.core, 3, 115200)) == 115200  # a rate it can do still works
    sim.close()


def test_a_port_that_is_gone_is_not_taken_for_a_refused_rate() -> None:
    clock = VirtualClock()
    sim = SimBus(clock=clock)
    sim.add_controller(id=3, baud=9600)
    bus, port = picky_bus(sim, clock)
    port.gone = True
    with pytest.raises(PortError) as raised:
        bus.run(discover(bus.core, rates=[115200]))
    assert not isinstance(raised.value, RateRefused)
    sim.close()
