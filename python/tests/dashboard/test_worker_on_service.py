"""The console's reads are a subscription of a bus service's poll schedule (issue 32). Virtual time."""

from __future__ import annotations

from typing import Any

from nurimc.dashboard import commands as c
from nurimc.dashboard.scheduler import Job
from nurimc.dashboard.worker import POLL_HZ, BusWorker
from nurimc.procedures.discovery import Found

from ..client.simfixtures import sim_bus


def test_the_watched_motors_are_read_by_the_services_schedule_through_the_consoles_handles() -> None:
    sim, bus = sim_bus([1, 2], baud=115200)
    events: list[dict[str, Any]] = []
    worker = BusWorker(bus, "mc", events.append)
    for i in (1, 2):
        worker._remember(Found(i, 115200, None))
    worker.watched = (1, 2)
    assert worker.service.poll_rates == {1: POLL_HZ, 2: POLL_HZ}
    assert worker.service.motor(1) is worker.motor(1)  # one handle per ID: one multi-turn history
    end = bus.clock.now() + 0.5
    while bus.clock.now() < end:  # the worker's thread steps the service between commands
        worker._poll()
        bus.clock.sleep(0.001)
    rows = worker.take_samples()
    per_motor = {i: sum(1 for r in rows if r[0] == i) for i in (1, 2)}
    assert all(0.8 * 0.5 * POLL_HZ <= n <= 0.5 * POLL_HZ + 2 for n in per_motor.values()), per_motor
    assert worker.service.reads == len(rows)  # every row is one of the service's reads
    assert all(len(r) == 7 and r[6] == 0 for r in rows)  # position_uncertain carried in each sample
    worker.watched = ()
    assert worker.service.poll_rates == {}
    worker._poll()
    assert worker.take_samples() == []
    worker.service.close()
    bus.close()
    sim.close()


def test_a_pages_command_is_a_service_job_and_the_stop_is_the_services() -> None:
    sim, bus = sim_bus([1, 2], baud=115200)
    events: list[dict[str, Any]] = []
    worker = BusWorker(bus, "mc", events.append)
    for i in (1, 2):
        worker._remember(Found(i, 115200, None))
    answers: list[tuple[Any, str | None]] = []
    requests = worker.service.me.requests
    sent = bus.core.commands_sent.get(1, 0)
    worker._carry_out(Job(c.RunMotor(1, 30.0, 0.1), lambda r, e: answers.append((r, e)), None, 0))
    assert answers[-1] == ({"id": 1}, None)
    assert worker.service.me.requests == requests + 1  # carried out as a job of the service
    assert bus.core.commands_sent.get(1, 0) > sent  # through BusCore.tell
    bus.clock.sleep(0.3)
    assert not sim.controller(1).settings.control  # turning
    worker._carry_out(Job(c.EmergencyStop(), lambda r, e: answers.append((r, e)), None, 0))
    result: dict[str, Any] = answers[-1][0]
    assert answers[-1][1] is None and result["stopped"] == [1, 2] and result["ok"], answers[-1]
    assert worker.service.generation == 1 and worker.service.latched == {1, 2}  # the service's one stop
    assert sim.controller(1).settings.control  # control off, read back
    assert events[-1]["type"] == "estop" and events[-1]["stopped"] == [1, 2]  # every page told
    worker.service.close()
    bus.close()
    sim.close()
