"""A step run is labelled with the gains read from the motor at its start (issue #37): never
with what was typed in the page's fields."""

from __future__ import annotations

from typing import Any

from nurimc.dashboard import commands as c
from nurimc.dashboard.procedures import gains_at_start
from nurimc.dashboard.worker import BusWorker, KnownMotor
from tests.client.simfixtures import sim_bus


def test_gains_at_start_are_the_motors() -> None:
    sim, bus = sim_bus([1], baud=115_200)
    with bus:
        bus.motor(1).set("position-kp", 17)
        assert bus.run(gains_at_start(bus.motor(1).procedures))["kp"] == 17
        settings = sim.controllers[0].settings
        assert bus.run(gains_at_start(bus.motor(1).procedures)) == {
            "kp": 17,
            "ki": settings.position_ki,
            "kd": settings.position_kd,
        }


def test_a_step_runs_label_is_the_gains_read_back() -> None:
    """The issue's case: Kp 5 typed (never written), the motor has Kp 17: the run says 17."""
    _sim, bus = sim_bus([1], baud=115_200, resolution=1024)
    published: list[dict[str, Any]] = []
    with bus:
        bus.motor(1).set("position-kp", 17)
        worker = BusWorker(bus, "mc", published.append)
        worker.motors[1] = KnownMotor(1, 115_200, None)
        result = worker._step(c.Step(1, 30.0, 60.0, 0.3))
        read_back = bus.motor(1).get("position-kp")
        assert result["gains"]["kp"] == read_back == 17
        assert result["gains"] == bus.run(gains_at_start(bus.motor(1).procedures))
