"""The console's Auto-tune ops (dashboard/tune_panel.py): parsing, the worker's handler, cancel."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from nurimc import Bus
from nurimc.dashboard import commands as c
from nurimc.dashboard import tune_panel
from nurimc.procedures.motor import Motor, MotorState
from nurimc.sim import SimBus
from nurimc.sim.plant import Plant

from .test_tuner import START, gains_on

Build = Callable[..., tuple[SimBus, Bus]]


class FakeWorker:
    """What run_tune uses of the BusWorker."""

    def __init__(self, bus: Bus, on_publish: Callable[[dict[str, Any]], None] | None = None) -> None:
        self.bus = bus
        self.published: list[dict[str, Any]] = []
        self.plotted: list[MotorState] = []
        self.on_publish = on_publish
        self.estop = False

    def motor(self, device_id: int) -> Motor:
        return self.bus.motor(device_id)

    def publish(self, event: dict[str, Any]) -> None:
        self.published.append(event)
        if self.on_publish is not None:
            self.on_publish(event)

    def _check_estop(self) -> None:
        if self.estop:
            raise RuntimeError("interrupted by the emergency stop")

    def _wrote_eeprom(self, device_id: int, why: str) -> None:
        pass

    def _plot(self, state: MotorState) -> None:
        self.plotted.append(state)


def test_tune_op_is_parsed_and_checked_before_the_bus() -> None:
    command: object = c.parse({"op": "tune", "id": 1, "goal": "smooth", "trials": 5, "travel": 20})
    assert command == c.Tune(1, "position", "smooth", 20.0, 30.0, 3.0, 5, None, None)
    assert isinstance(c.parse({"op": "tune_cancel"}), tune_panel.TuneCancel)
    for message, said in [
        ({"op": "tune", "id": 1, "goal": "fast"}, "goal must be one of"),
        ({"op": "tune", "id": 1, "trials": 2.5}, "whole number 2..60"),
        ({"op": "tune", "id": 1, "travel": 2}, "too small to measure a step"),
        ({"op": "tune", "id": 1, "loop": "torque"}, "use position or speed"),
        ({"op": "tune", "id": 1, "max_rpm": "fast"}, "must be a number"),
        ({"op": "tune", "id": 1, "max_overshoot": -1}, "give a percentage"),
    ]:
        with pytest.raises(c.CommandError, match=said):
            c.parse(message)


def test_worker_handler_publishes_each_trial_and_writes_the_starting_gains_back(make_sim_bus: Build) -> None:
    sim, bus = make_sim_bus([1], baud=115200, resolution=1024)
    sim.controllers[0].set_plant(Plant(inertia=3.0))
    worker = FakeWorker(bus)
    answer = tune_panel.run_tune(worker, tune_panel.parse_tune({"op": "tune", "id": 1, "trials": 5}))
    assert answer["cancelled"] is False and answer["restored"] is True
    assert len(answer["trials"]) == 5 and answer["chosen_gains"] is not None
    trials = [e for e in worker.published if e["event"] == "trial"]
    starts = [e for e in worker.published if e["event"] == "start"]
    assert [e["trial"] for e in trials] == [1, 2, 3, 4, 5] and len(starts) == 5
    first = trials[0]
    assert first["gains"] == {"kp": 50, "ki": 0, "kd": 10} and len(first["times"]) == len(first["values"]) > 10
    assert first["target"] - first["start"] == pytest.approx(15.0)
    assert gains_on(sim) == START  # the page applies the chosen gains itself, with `set`
    assert len(worker.plotted) > 50 and {s.id for s in worker.plotted} == {1}  # the live plots follow the tune


def test_cancel_mid_tune_restores_the_starting_gains(make_sim_bus: Build) -> None:
    sim, bus = make_sim_bus([1], baud=115200, resolution=1024)
    sim.controllers[0].set_plant(Plant(inertia=3.0))

    def cancel_at_three(event: dict[str, Any]) -> None:
        if event["event"] == "start" and event["trial"] == 3:
            tune_panel.cancel()  # what the server does when the page sends tune_cancel

    worker = FakeWorker(bus, cancel_at_three)
    answer = tune_panel.run_tune(worker, tune_panel.parse_tune({"op": "tune", "id": 1, "trials": 10}))
    assert answer["cancelled"] is True and answer["restored"] is True
    assert len(answer["trials"]) == 2
    assert gains_on(sim) == START
    assert not tune_panel.CANCEL.is_set()
