"""`nurimc tune` in process, on a simulated plant on virtual time (open_bus points at it)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nurimc import Bus
from nurimc.procedures.journal import RestoreJournal
from nurimc.sim import SimBus
from nurimc.sim.plant import Plant

from ..cli.inprocess import assert_clean, nurimc
from ..client.simfixtures import bus_on, sim_bus
from .test_tuner import START, gains_on, independent_step

PORT = "sim://?ids=1&state=/nowhere"  # a key for the restore journal (state=: a bus one comes back to)


@pytest.fixture
def plant_bus(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> SimBus:
    monkeypatch.setenv("NURIMC_STATE_DIR", str(tmp_path / "state"))
    sim, _ = sim_bus([1], baud=115200, resolution=1024)
    sim.controllers[0].set_plant(Plant(inertia=4.0))
    monkeypatch.setattr("nurimc.cli.tune_cmd.open_bus", lambda o: bus_on(sim, 115200, busy_window=0.05))
    return sim


def test_tune_apply_writes_gains_that_beat_the_start_measured_afterwards(plant_bus: SimBus, tmp_path: Path) -> None:
    args = ("--port", PORT, "--id", "1", "--product", "mc", "--json", "tune", "--goal", "no-overshoot", "--apply")
    result = nurimc(*args, "--trials", "16")
    assert_clean(result, *args)
    assert result.code == 0, result.err
    document = json.loads(result.out)
    assert document["applied"] is True and 2 <= len(document["trials"]) <= 16
    chosen = tuple(document["chosen_gains"][k] for k in ("kp", "ki", "kd"))
    assert gains_on(plant_bus) == chosen != START
    assert RestoreJournal(PORT).pending(1) is None  # ended cleanly: nothing left to restore
    bus: Bus = bus_on(plant_bus, 115200, busy_window=0.05)
    before, after = independent_step(bus, START), independent_step(bus, chosen)
    assert after.overshoot < before.overshoot
    assert before.settling_time is not None and after.settling_time is not None
    assert after.settling_time <= before.settling_time


def test_tune_without_apply_and_no_terminal_keeps_the_starting_gains(plant_bus: SimBus) -> None:
    result = nurimc("--port", PORT, "--id", "1", "--product", "mc", "tune", "--trials", "4")
    assert result.code == 0, result.err
    assert "not applied: run with --apply" in result.err
    assert "chosen against starting gains" in result.out and "trial" in result.out
    assert gains_on(plant_bus) == START


def test_too_small_an_envelope_is_refused_before_the_port_is_used(plant_bus: SimBus) -> None:
    received = plant_bus.controllers[0].frames_received
    args = ("--port", PORT, "--id", "1", "--product", "mc", "tune", "--travel", "2")
    result = nurimc(*args)
    assert_clean(result, *args)
    assert result.code == 2 and "too small to measure a step" in result.err
    assert plant_bus.controllers[0].frames_received == received


def test_korean_messages_of_tune(plant_bus: SimBus, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LANGUAGE", "ko")
    result = nurimc("--port", PORT, "--id", "1", "--product", "mc", "tune", "--trials", "3")
    assert result.code == 0, result.err
    assert "--apply" in result.err and "적용" in result.err


def test_a_lost_port_leaves_the_journal_and_restore_writes_the_starting_gains_back(
    plant_bus: SimBus, monkeypatch: pytest.MonkeyPatch
) -> None:
    from nurimc.errors import PortLost
    from nurimc.procedures.tuning import Tuner

    real = Tuner._position_trial
    calls: list[int] = []

    def flaky(self: Tuner, number: int, gains: tuple[int, int, int]) -> Any:
        calls.append(number)
        if number == 3:
            plant_bus.controllers[0].settings.position_kp = gains[0]  # the trial's gains were written
            raise PortLost("the port went away (unplugged?)")
        return (yield from real(self, number, gains))

    monkeypatch.setattr(Tuner, "_position_trial", flaky)
    result = nurimc("--port", PORT, "--id", "1", "--product", "mc", "tune", "--trials", "10")
    assert result.code == 1
    assert "could NOT restore the starting gains kp 50, ki 0, kd 10" in result.err
    saved = RestoreJournal(PORT).pending(1)
    assert saved is not None and f"restore {saved}" in " ".join(result.err.split())
    assert gains_on(plant_bus) != START
    monkeypatch.setattr("nurimc.cli.settings_cmd.open_bus", lambda o: bus_on(plant_bus, 115200, busy_window=0.05))
    restored = nurimc("--port", PORT, "--product", "mc", "restore", saved)
    assert restored.code == 0, restored.err
    assert gains_on(plant_bus) == START
    assert RestoreJournal(PORT).pending(1) is None


def test_ctrl_c_mid_tune_restores_the_starting_gains_and_says_so(
    plant_bus: SimBus, monkeypatch: pytest.MonkeyPatch
) -> None:
    from nurimc.procedures.tuning import Tuner

    real = Tuner._position_trial

    def interrupted(self: Tuner, number: int, gains: tuple[int, int, int]) -> Any:
        if number == 3:
            raise KeyboardInterrupt  # as the driver throws it in when Ctrl+C lands mid-trial
        return (yield from real(self, number, gains))

    monkeypatch.setattr(Tuner, "_position_trial", interrupted)
    result = nurimc("--port", PORT, "--id", "1", "--product", "mc", "tune", "--trials", "10")
    assert result.code == 130
    assert "stopped: restored the starting gains kp 50, ki 0, kd 10 (read back)" in result.err
    assert gains_on(plant_bus) == START
    assert RestoreJournal(PORT).pending(1) is None
