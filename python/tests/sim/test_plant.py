"""Plant parameters (sim/plant.py): a simulated controller standing for other motors and loads."""

from __future__ import annotations

import json
import statistics
from pathlib import Path

import pytest

from nurimc.sim import SimBus
from nurimc.sim.cli import apply_plants, build_bus
from nurimc.sim.controller import SimController
from nurimc.sim.faults import FaultConfig
from nurimc.sim.plant import Plant, PlantError, parse_plant
from nurimc.sim.profile import load_profiles
from nurimc.sim.servo import DT


def controller(plant: Plant | None = None) -> tuple[SimBus, SimController]:
    bus = SimBus()
    c = bus.add_controller(1)
    c.settings.resolution = 1024
    c.apply_settings()
    if plant is not None:
        c.set_plant(plant)
    return bus, c


def trace(c: SimController, target: float, seconds: float, rpm: float = 120.0) -> list[float]:
    """Readings every ms after a move to `target` at `rpm`."""
    c.servo.move_at_speed(target, rpm * 6)
    out = []
    for _ in range(round(seconds / DT)):
        c.servo.advance(DT)
        out.append(c.servo.measured_angle())
    return out


def first_at(readings: list[float], level: float) -> int:
    return next(i for i, p in enumerate(readings) if p >= level)


def test_parse_plant_reads_keys_and_refuses_bad_input_in_one_line() -> None:
    assert parse_plant("3:inertia=2,backlash=0.5") == (3, Plant(inertia=2.0, backlash=0.5))
    assert parse_plant("0x10: noise = 0.1") == (16, Plant(noise=0.1))
    for bad, said in [
        ("inertia=2", "ID:KEY=VALUE"),
        ("1:", "ID:KEY=VALUE"),
        ("x:inertia=2", "not a number"),
        ("300:inertia=2", "out of range"),
        ("1:mass=2", "unknown plant key 'mass'"),
        ("1:inertia", "not KEY=VALUE"),
        ("1:inertia=heavy", "not a number"),
        ("1:inertia=0", "out of range"),
        ("1:delay=2", "out of range"),
        ("1:noise=nan", "not a number"),
    ]:
        with pytest.raises(PlantError, match=said) as info:
            parse_plant(bad)
        assert "\n" not in str(info.value)


def test_default_plant_is_todays_model() -> None:
    _, today = controller()
    _, explicit = controller(Plant())
    assert trace(today, 90.0, 1.0) == trace(explicit, 90.0, 1.0)


def test_heavier_motor_is_slower_and_overshoots_more_lighter_faster() -> None:
    runs = {k: trace(controller(Plant(inertia=k))[1], 90.0, 1.5, rpm=3000) for k in (0.5, 1.0, 4.0)}
    start = {k: first_at(r, 9.0) for k, r in runs.items()}  # 10 % of the step: how fast it gets going
    assert start[0.5] < start[1.0] < start[4.0]
    assert first_at(runs[4.0], 81.0) > first_at(runs[1.0], 81.0)
    assert max(runs[4.0]) > max(runs[1.0]) + 2.0  # the same gains brake a heavier load too late


def test_friction_multiples_take_speed_away_when_coasting() -> None:
    speeds = {}
    for key in ("viscous", "coulomb"):
        for k in (1.0, 5.0):
            _, c = controller(Plant(**{key: k}))
            c.servo.release()
            c.servo.motor.speed = 1000.0
            c.servo.advance(0.5)
            speeds[key, k] = c.servo.motor.speed
    assert speeds["viscous", 5.0] < speeds["viscous", 1.0]
    assert speeds["coulomb", 5.0] < speeds["coulomb", 1.0]


def test_backlash_reading_lags_the_motor_by_the_play_on_a_reversal() -> None:
    _, c = controller(Plant(backlash=4.0))
    c.servo.release()
    c.servo.motor.speed = 200.0  # coast forward: the output is dragged along, half the play behind
    c.servo.advance(0.2)
    forward = c.servo.motor.angle - c.servo.measured_angle()
    assert forward == pytest.approx(2.0, abs=0.1)
    c.servo.motor.speed = -200.0  # reverse: the reading stands still while the play is crossed
    before = c.servo.measured_angle()
    c.servo.advance(0.01)
    assert c.servo.measured_angle() == pytest.approx(before, abs=0.1)
    assert c.servo.motor.angle < before + 2.0


def readings_at_rest(c: SimController, n: int) -> list[float]:
    out = []
    for _ in range(n):
        c.servo.advance(DT)
        out.append(c.servo.measured_angle())
    return out


def test_noise_is_the_std_of_the_reading_and_seeded() -> None:
    readings = readings_at_rest(controller(Plant(noise=0.5))[1], 400)
    assert 0.35 < statistics.pstdev(readings) < 0.65
    assert readings_at_rest(controller(Plant(noise=0.5))[1], 400) == readings


def test_delay_is_dead_time_before_the_drive_acts() -> None:
    quick = trace(controller()[1], 90.0, 0.2)
    late = trace(controller(Plant(delay=0.05))[1], 90.0, 0.2)
    assert first_at(quick, 0.1) < 10
    assert first_at(late, 0.1) >= 49


def test_profile_file_gives_a_product_its_plant(tmp_path: Path) -> None:
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"profiles": {"mc": {"plant": {"inertia": 3, "noise": 0.1}}}}))
    profiles = load_profiles(path)
    assert profiles["mc"].plant == Plant(inertia=3.0, noise=0.1)
    bus = SimBus(profiles=profiles)
    try:
        assert bus.add_controller(2).servo.plant == Plant(inertia=3.0, noise=0.1)
    finally:
        bus.close()
    for bad, said in [({"inertia": "x"}, "not a number"), ({"weight": 1}, "unknown plant key"), ([1], "not an object")]:
        path.write_text(json.dumps({"profiles": {"mc": {"plant": bad}}}))
        with pytest.raises(ValueError, match=said):
            load_profiles(path)


def test_cli_plant_option_applies_per_id_and_refuses_unknown_ids() -> None:
    bus = build_bus("1,2", 9600, [], "mc", None, False, 0, FaultConfig())
    try:
        apply_plants(bus, ["2:inertia=2,delay=0.01"])
        plants = {c.id: c.servo.plant for c in bus.controllers}
        assert plants == {1: Plant(), 2: Plant(inertia=2.0, delay=0.01)}
    finally:
        bus.close()
    bus = build_bus("1", 9600, [], "mc", None, False, 0, FaultConfig())
    with pytest.raises(ValueError, match="no controller has ID 5"):
        apply_plants(bus, ["5:inertia=2"])


def test_sim_url_takes_plant_parameters() -> None:
    from nurimc.sim.options import OptionError
    from nurimc.sim.urlhandler.protocol_sim import bus_from_url

    bus = bus_from_url("sim://?ids=1,2&plant=2:inertia=3,backlash=0.3")
    try:
        assert {c.id: c.servo.plant for c in bus.controllers} == {1: Plant(), 2: Plant(inertia=3.0, backlash=0.3)}
    finally:
        bus.close()
    for url, said in [
        ("sim://?ids=1&plant=7:inertia=2", "sim:// URL: plant='7:inertia=2': no controller has ID 7"),
        ("sim://?ids=1&plant=1:mass=2", "unknown plant key 'mass'"),
    ]:
        with pytest.raises(OptionError, match=said):
            bus_from_url(url)
