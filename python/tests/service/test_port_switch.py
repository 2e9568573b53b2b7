"""Port switching is a stop first (issue 39, item 1): the console stops and reads back every
motor it commanded on the port it leaves, or refuses the switch naming them. Virtual time."""

from __future__ import annotations

from typing import Any

import pytest

from nurimc.dashboard import commands as c
from nurimc.dashboard.worker import BusWorker
from nurimc.procedures.discovery import Found

from ..client.simfixtures import sim_bus


def worker_on(ids: list[int]) -> tuple[Any, BusWorker, list[dict[str, Any]]]:
    sim, bus = sim_bus(ids, baud=115200)
    events: list[dict[str, Any]] = []
    worker = BusWorker(bus, "mc", events.append, port="/dev/old-port")
    for i in ids:
        worker._remember(Found(i, 115200, None))
    return sim, worker, events


def test_the_console_stops_what_it_commanded_before_leaving_the_port() -> None:
    sim, worker, _ = worker_on([1, 2])
    worker._execute(c.RunMotor(1, 30.0, 0.1))
    worker.bus.clock.sleep(0.3)
    assert not sim.controller(1).settings.control  # turning
    result = worker._open_bus("loop://", 115200)
    assert result["stopped_before_leaving"] == [1]
    assert sim.controller(1).settings.control  # control off, read back before the switch
    assert worker.port == "loop://" and worker.commanded == set()
    worker.bus.close()
    sim.close()


def test_a_motor_that_does_not_read_back_off_refuses_the_switch() -> None:
    sim, worker, _ = worker_on([1, 2])
    worker._execute(c.RunMotor(2, 30.0, 0.1))
    gone = sim.controller(2)
    with sim.lock:
        sim.controllers.remove(gone)
        sim._forget_index()
    with pytest.raises(ValueError, match=r"cannot leave /dev/old-port: ID 2 did not read back off"):
        worker._open_bus("loop://", 115200)
    assert worker.port == "/dev/old-port" and worker.commanded == {2}
    worker.bus.close()
    sim.close()


def test_the_consoles_stop_names_what_it_could_not_read_back() -> None:
    sim, worker, events = worker_on([1, 2])
    with sim.lock:
        sim.controllers.remove(sim.controller(2))
        sim._forget_index()
    result = worker._stop_now()
    assert result["stopped"] == [1] and result["not_confirmed"] == [2] and not result["ok"]
    assert events[-1]["type"] == "estop" and events[-1]["not_confirmed"] == [2]  # every page is told
    worker.bus.close()
    sim.close()


def test_the_console_keeps_reading_while_its_stop_reads_back_and_backs_off_a_silent_motor() -> None:
    sim, worker, events = worker_on([1, 2, 3])
    worker.watched = (1, 2, 3)
    worker._execute(c.RunMotor(1, 60.0, 0.1))
    worker.bus.clock.sleep(0.3)
    with sim.lock:  # motor 3 never confirms: the stop reads back for its whole window
        sim.controllers.remove(sim.controller(3))
        sim._forget_index()
    t0 = worker.bus.clock.now()
    worker._stop_now()
    t1 = worker.bus.clock.now()
    rows = worker.take_samples()
    of_1 = [r for r in rows if r[0] == 1]
    assert t1 - t0 >= 2.0 and len(of_1) >= 0.5 * (t1 - t0) / 0.02, (len(of_1), t1 - t0)  # still read while coasting
    assert any(e["type"] == "motor_silent" and e["id"] == 3 for e in events)
    attempts_3 = worker.silent.failures.get(3, 0)
    assert attempts_3 <= 12  # one try per backoff period, not one per poll
    worker.bus.close()
    sim.close()
