"""A program's loop on the bus service's polls (service/readings.py), on virtual time."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from nurimc.drivers.sync import Bus
from nurimc.errors import NurimcError
from nurimc.procedures.motor import MotorState
from nurimc.service import BusService
from nurimc.service.readings import ServiceReadings
from nurimc.sim import SimBus

from ..client.simfixtures import sim_bus

RATE = 115200


@pytest.fixture
def pair() -> Iterator[tuple[SimBus, Bus]]:
    sim, bus = sim_bus([1, 2], baud=RATE)
    yield sim, bus
    bus.close()
    sim.close()


def test_rounds_come_at_the_rate_asked_and_share_the_reads(pair: tuple[SimBus, Bus]) -> None:
    _sim, bus = pair
    service = BusService(bus)
    record = ServiceReadings(service, [1, 2], 20)
    other = ServiceReadings(service, [2], 50)
    taken = 0
    for _ in range(20):  # one second: a reading of each motor every 50 ms
        service.run_for(0.05)
        got = record.take(0)  # the latest of each motor since the last take
        assert all(isinstance(v, MotorState) for v in got.values())
        taken += len(got)
    assert 36 <= record.subscription.delivered <= 42, record.subscription.delivered
    assert taken >= 28, taken  # two readings of one motor within one take count once
    other.take(0)
    # motor 2 read at 50/s for both, motor 1 at 20/s: never once per subscriber
    assert service.reads <= 20 + 50 + 2, service.reads
    record.close()
    assert service.poll_rates == {2: 50.0}


def test_a_silent_motor_comes_as_its_error(pair: tuple[SimBus, Bus]) -> None:
    _sim, bus = pair
    service = BusService(bus)
    readings = ServiceReadings(service, [1, 7], 0)  # 7 is not on the bus; 0: as fast as the bus allows
    service.run_for(0.2)
    got = readings.take(0)
    assert isinstance(got[1], MotorState)
    assert isinstance(got[7], NurimcError)
    assert isinstance(readings.latest()[1], MotorState)
    assert readings.take(0) == {}  # taken: nothing new until the service reads again
