"""The bus service on virtual time with the in-process simulator (docs/service.md)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from nurimc.drivers.sync import Bus
from nurimc.service import COMMAND, READ, BusService, Cancelled, Sample
from nurimc.service.core import BACKOFF_MAX
from nurimc.sim import SimBus

from ..client.simfixtures import sim_bus

RATE = 115200


@pytest.fixture
def pair() -> Iterator[tuple[SimBus, Bus]]:
    sim, bus = sim_bus([1, 2, 3], baud=RATE)
    yield sim, bus
    bus.close()
    sim.close()


def service_on(bus: Bus, ids: tuple[int, ...] = (1, 2, 3)) -> BusService:
    return BusService(bus, motors={i: RATE for i in ids})


def unplug(sim: SimBus, device_id: int) -> Any:
    controller = sim.controller(device_id)
    with sim.lock:
        sim.controllers.remove(controller)
        sim._forget_index()
    return controller


def plug(sim: SimBus, controller: Any) -> None:
    with sim.lock:
        sim.controllers.append(controller)
        sim._forget_index()


def test_one_poll_schedule_is_shared_by_every_subscriber(pair: tuple[SimBus, Bus]) -> None:
    _sim, bus = pair
    service = service_on(bus)
    fast: list[Sample] = []
    slow: list[Sample] = []
    service.subscribe([1, 2], 50, fast.append)
    service.subscribe([2], 20, slow.append)
    assert service.poll_rates == {1: 50.0, 2: 50.0}
    service.run_for(2.0)
    per_motor = {i: sum(1 for s in fast if s.id == i) for i in (1, 2)}
    assert all(90 <= n <= 102 for n in per_motor.values()), per_motor
    assert 36 <= len(slow) <= 41, len(slow)
    # the bus was read once per due time for both subscribers, never once per subscriber
    assert service.reads == sum(per_motor.values())
    assert all(s.state is not None and s.error is None for s in fast + slow)


def test_a_motor_that_stops_answering_backs_off_and_the_others_keep_their_rate(pair: tuple[SimBus, Bus]) -> None:
    sim, bus = pair
    service = service_on(bus)
    samples: list[Sample] = []
    events: list[dict[str, Any]] = []
    service.listen(events.append)
    service.subscribe([1, 2, 3], 40, samples.append)
    service.run_for(1.0)
    alone = {i: sum(1 for s in samples if s.id == i and s.state) for i in (1, 2)}
    samples.clear()
    gone = unplug(sim, 3)
    service.run_for(3.0)
    live = {i: sum(1 for s in samples if s.id == i and s.state) / 3.0 for i in (1, 2)}
    assert all(live[i] >= 0.8 * alone[i] for i in (1, 2)), (alone, live)
    attempts = sum(1 for s in samples if s.id == 3)
    assert attempts <= 12, attempts  # backed off to one try a second, not 40 a second
    silent = [e for e in events if e["type"] == "no_answer"]
    assert [e["id"] for e in silent] == [3]
    assert samples[-1].id != 3 or samples[-1].silent_since == silent[0]["since"]
    plug(sim, gone)
    samples.clear()
    back_at = bus.clock.now()
    service.run_for(3.0)
    assert any(e["type"] == "answering" and e["id"] == 3 for e in events)
    answers = [s.t for s in samples if s.id == 3 and s.state]
    assert answers[0] - back_at <= BACKOFF_MAX + 0.05  # picked up at the next try
    assert len(answers) >= 0.8 * 40 * (answers[-1] - answers[0])  # then back at its rate


def test_the_emergency_stop_reads_every_motor_back_off_and_latches(pair: tuple[SimBus, Bus]) -> None:
    sim, bus = pair
    service = service_on(bus)
    for i in (1, 2, 3):
        service.run(service.motor(i).procedures.run(30), commands=[i])
    service.run_for(0.5)
    assert all(not sim.controller(i).settings.control for i in (1, 2, 3))  # control on: turning
    events: list[dict[str, Any]] = []
    service.listen(events.append)
    result = service.emergency_stop()
    assert result.ok and result.stopped == (1, 2, 3) and result.not_confirmed == ()
    assert all(sim.controller(i).settings.control for i in (1, 2, 3))  # control off on every one
    assert service.latched == {1, 2, 3}
    assert [e["type"] for e in events] == ["estop"] and events[0]["stopped"] == [1, 2, 3]
    service.run(lambda b: service.motor(2).run(10), commands=[2])  # commanding a motor clears its latch
    assert service.latched == {1, 3}


def test_the_stop_names_what_it_could_not_read_back(pair: tuple[SimBus, Bus]) -> None:
    sim, bus = pair
    service = service_on(bus)
    unplug(sim, 2)
    t0 = bus.clock.now()
    result = service.emergency_stop()
    assert result.stopped == (1, 3) and result.not_confirmed == (2,) and not result.ok
    assert bus.clock.now() - t0 >= service.stop_window  # it tried for the whole window
    assert "ID 2 NOT confirmed" in result.text()
    nothing = BusService(bus).emergency_stop()  # no motor known: never "ok" with nothing read
    assert not nothing.ok and "not confirmed" in nothing.text()


def test_a_stop_wins_over_everything_queued_before_it(pair: tuple[SimBus, Bus]) -> None:
    sim, bus = pair
    service = service_on(bus)
    queued = service.submit(lambda b: service.motor(1).run(30), priority=COMMAND, commands=[1])
    read = service.submit(lambda b: service.motor(2).read_state(), priority=READ)
    service.emergency_stop()
    with pytest.raises(Cancelled):
        queued.result(timeout=0)
    with pytest.raises(Cancelled):
        read.result(timeout=0)
    assert sim.controller(1).settings.control  # the run queued before the stop never went out


def test_polling_goes_on_during_and_after_the_stop(pair: tuple[SimBus, Bus]) -> None:
    sim, bus = pair
    service = service_on(bus, (1, 2, 3))
    service.run(lambda b: service.motor(1).run(60), commands=[1])
    gone = unplug(sim, 3)  # one motor never confirms: the stop reads back for its whole window
    samples: list[Sample] = []
    service.subscribe([1], 50, samples.append)
    service.run_for(0.2)
    t0 = bus.clock.now()
    result = service.emergency_stop()
    t1 = bus.clock.now()
    during = [s for s in samples if t0 <= s.t <= t1 and s.state]
    assert result.not_confirmed == (3,)
    assert len(during) >= 0.8 * 50 * (t1 - t0), (len(during), t1 - t0)
    plug(sim, gone)
    samples.clear()
    service.run_for(1.0)
    assert len(samples) >= 45


def test_a_failing_subscriber_does_not_stop_the_others(pair: tuple[SimBus, Bus]) -> None:
    _sim, bus = pair
    said: list[str] = []
    service = BusService(bus, motors={1: RATE}, say=said.append)
    good: list[Sample] = []

    def bad(sample: Sample) -> None:
        raise RuntimeError("bug")

    service.subscribe([1], 20, bad)
    service.subscribe([1], 20, good.append)
    service.run_for(0.5)
    assert len(good) >= 9 and said and "bug" in said[0]


def test_bad_rates_are_refused(pair: tuple[SimBus, Bus]) -> None:
    _, bus = pair
    service = service_on(bus)
    with pytest.raises(ValueError, match="above 0"):
        service.subscribe([1], 0, lambda s: None)


def test_readings_the_holder_makes_itself_are_shared_not_read_again(pair: tuple[SimBus, Bus]) -> None:
    _, bus = pair
    service = service_on(bus)
    got: list[Sample] = []
    service.subscribe([1], 10, got.append)
    end = bus.clock.now() + 2.0
    while bus.clock.now() < end:  # the holder's own loop reads motor 1 at 50 Hz and offers each reading
        service.offer(service.run(service.motor(1).procedures.read_state()))
        service.run_for(0.02)
    assert service.reads == 0  # the service never read the bus for its subscriber
    assert 18 <= len(got) <= 21  # 10 a second, from the holder's readings


def test_a_stop_of_the_holder_program_itself_is_told_to_every_program_and_latched(pair: tuple[SimBus, Bus]) -> None:
    _, bus = pair
    service = service_on(bus)
    events: list[dict[str, Any]] = []
    service.listen(events.append)
    service.announce({"type": "estop", "from": "nurimc ros2", "stopped": [1, 2], "not_confirmed": [3]})
    assert events[-1]["from"] == "nurimc ros2" and service.latched == {1, 2, 3}
