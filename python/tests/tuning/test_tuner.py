"""The tuner (nurimc.procedures.tuning) against simulated plants it was not written for, on virtual time."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from nurimc import Bus
from nurimc.errors import PortLost
from nurimc.procedures.stepresponse import ResponseFigures, response_figures
from nurimc.procedures.tuning import NONE_MEASURED, TrialDone, TrialSample, TrialStarted, TuneRefused, TuneStopped
from nurimc.sim import SimBus
from nurimc.sim.plant import Plant

from ..client.simfixtures import sim_bus

Build = Callable[..., tuple[SimBus, Bus]]
START = (50, 0, 10)  # the MC profile's factory position gains


def on_plant(make_sim_bus: Build, plant: Plant) -> tuple[SimBus, Bus]:
    sim, bus = make_sim_bus([1], baud=115200, resolution=1024)
    sim.controllers[0].set_plant(plant)
    return sim, bus


def gains_on(sim: SimBus) -> tuple[int, int, int]:
    s = sim.controllers[0].settings
    return s.position_kp, s.position_ki, s.position_kd


def independent_step(bus: Bus, gains: tuple[int, int, int], step: float = 15.0, rpm: float = 30.0) -> ResponseFigures:
    """A step measured here, not by the tuner: write the gains, step, sample for 1.2 s."""
    motor = bus.motor(1)
    motor.set("position-kp", gains[0])
    motor.set("position-ki", gains[1])
    motor.set("position-kd", gains[2])
    motor.hold()
    bus.clock.sleep(0.5)
    start = motor.read_state().device_position
    motor.move_to(start + step, rpm=rpm)
    began = bus.clock.now()
    times: list[float] = []
    values: list[float] = []
    while (t := bus.clock.now() - began) < 1.2:
        times.append(t)
        values.append(motor.read_state().device_position)
        bus.clock.sleep(0.005)
    return response_figures(times, values, start, start + step, min_band=0.5)


PLANTS = [
    Plant(inertia=4.0),  # heavier
    Plant(inertia=0.3),  # lighter
    Plant(coulomb=5.0, viscous=3.0),  # more friction
    Plant(backlash=1.0),
    Plant(noise=0.05),
    Plant(inertia=2.0, delay=0.01),
]


@pytest.mark.parametrize("plant", PLANTS, ids=lambda p: p.describe())
def test_no_overshoot_tune_beats_the_starting_gains_and_stays_in_the_envelope(
    make_sim_bus: Build, plant: Plant
) -> None:
    sim, bus = on_plant(make_sim_bus, plant)
    true_angles: list[float] = []
    home = sim.controllers[0].servo.motor.angle

    def watch(event: Any) -> None:
        if isinstance(event, TrialSample):  # where the motor really is, during every trial
            true_angles.append(sim.controllers[0].servo.motor.angle)

    result = bus.run(
        bus.motor(1).procedures.tune("position", goal="no-overshoot", trials=20, apply=True), on_note=watch
    )
    assert result.applied and result.best is not None
    assert 2 <= len(result.trials) <= 20
    assert result.start_gains == START
    assert gains_on(sim) == result.best.gains
    assert true_angles and max(abs(a - home) for a in true_angles) <= 30.0
    before = independent_step(bus, START)
    after = independent_step(bus, result.best.gains)
    assert after.settled
    assert after.overshoot <= before.overshoot
    if before.overshoot > 1.0:
        assert after.overshoot < before.overshoot
    assert before.settling_time is not None and after.settling_time is not None
    assert after.settling_time <= before.settling_time


def test_sync_and_async_handles_have_tune(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=3.0))
    result = bus.motor(1).tune(goal="stiff", trials=4)
    assert len(result.trials) == 4
    assert gains_on(sim) == START  # not applied: the starting gains are back
    assert result.as_dict()["trials"][0]["gains"] == {"kp": 50, "ki": 0, "kd": 10}


def test_ctrl_c_mid_tune_restores_the_starting_gains(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=4.0))

    def interrupt(event: Any) -> None:
        if isinstance(event, TrialSample) and event.number == 3 and event.t > 0.05:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        bus.run(bus.motor(1).procedures.tune("position", trials=20), on_note=interrupt)
    assert gains_on(sim) == START
    motor = bus.motor(1)
    assert (motor.get("position-kp"), motor.get("position-ki"), motor.get("position-kd")) == START


def test_estop_from_another_program_stops_restores_and_moves_nothing(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=4.0))
    controller = sim.controllers[0]

    def estop(event: Any) -> None:
        if isinstance(event, TrialStarted) and event.number == 3:  # another program: control off
            controller.settings.control = 1
            controller.servo.release()

    with pytest.raises(TuneStopped, match="control is off and the tuner did not turn it off") as info:
        bus.run(bus.motor(1).procedures.tune("position", trials=20), on_note=estop)
    assert "restored the starting gains kp 50, ki 0, kd 10 (read back)" in str(info.value)
    assert info.value.restored and info.value.result is not None and len(info.value.result.trials) == 2
    assert gains_on(sim) == START
    assert controller.settings.control == 1  # still off: the tuner did not turn it back on


def test_lost_port_says_nothing_could_be_restored(make_sim_bus: Build) -> None:
    _, bus = on_plant(make_sim_bus, Plant())

    def lose(event: Any) -> None:
        if isinstance(event, TrialStarted) and event.number == 2:
            raise PortLost("the port is gone")

    with pytest.raises(TuneStopped, match="could NOT restore the starting gains kp 50, ki 0, kd 10") as info:
        bus.run(bus.motor(1).procedures.tune("position", trials=20), on_note=lose)
    assert not info.value.restored


def test_envelope_too_small_is_refused_before_anything_is_sent(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant())
    received = sim.controllers[0].frames_received
    cases: list[tuple[dict[str, Any], str]] = [
        ({"travel": 3.0}, "too small to measure a step"),
        ({"loop": "speed", "travel": 10.0, "max_rpm": 100.0}, "too short to measure a speed step"),
        ({"max_rpm": 0.0}, "at least 1 RPM"),
        ({"max_current": 0.0}, "0.1..25.4 A"),
        ({"goal": "fast"}, "use one of stiff, smooth, no-overshoot"),
        ({"loop": "torque"}, "use position or speed"),
        ({"trials": 1}, "give 2..500"),
    ]
    for kwargs, said in cases:
        with pytest.raises(TuneRefused, match=said):
            bus.motor(1).tune(**kwargs)
    assert sim.controllers[0].frames_received == received


def test_a_goal_that_cannot_be_met_ends_with_the_best_and_names_the_limit(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=2.0))
    result = bus.motor(1).tune(max_overshoot=0.0, max_settling=0.01, trials=6)
    assert result.best is not None and len(result.trials) == 6
    assert any("settling" in limit for limit in result.unmet)
    assert result.best.score == min(t.score for t in result.trials)
    assert gains_on(sim) == START


def test_a_trial_leaving_the_envelope_is_aborted_with_control_off_and_never_retried(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=3.0))
    motor = bus.motor(1)
    motor.set("position-kp", 254)
    motor.set("position-ki", 254)
    home = sim.controllers[0].servo.motor.angle
    released: list[bool] = []
    angles: list[float] = []

    def watch(event: Any) -> None:
        if isinstance(event, TrialSample):
            angles.append(sim.controllers[0].servo.motor.angle)
        if isinstance(event, TrialDone) and event.trial.aborted:
            released.append(sim.controllers[0].settings.control == 1)

    result = bus.run(motor.procedures.tune("position", travel=10.0, max_current=1.0, trials=8), on_note=watch)
    assert len(result.trials) == 8 and all(t.aborted and "too much current" in t.aborted for t in result.trials)
    assert len(released) == 8 and all(released)  # control was off when each aborted trial was reported
    tried = [t.gains for t in result.trials]
    assert len(tried) == len(set(tried))
    assert max(abs(a - home) for a in angles) <= 10.0  # each trial began back inside the envelope
    assert result.best is None and result.unmet == [NONE_MEASURED]
    assert gains_on(sim) == (254, 254, 10)
    assert sim.controllers[0].settings.control == 0  # holding again at the end


def test_a_gentler_candidate_is_measured_after_aborted_ones(make_sim_bus: Build) -> None:
    _, bus = on_plant(make_sim_bus, Plant(inertia=3.0))
    motor = bus.motor(1)
    motor.set("position-kp", 120)
    result = bus.run(motor.procedures.tune("position", goal="stiff", travel=20.0, max_current=1.0, trials=10))
    aborted = [t for t in result.trials if t.aborted]
    measured = [t for t in result.trials if t.figures is not None]
    assert aborted and measured
    assert result.best is not None and result.best.figures is not None
    assert result.best.figures.current_peak <= 1.0


def test_speed_loop_tune_runs_inside_the_envelope(make_sim_bus: Build) -> None:
    sim, bus = on_plant(make_sim_bus, Plant(inertia=2.0))
    home = sim.controllers[0].servo.motor.angle
    angles: list[float] = []
    result = bus.run(
        bus.motor(1).procedures.tune("speed", goal="smooth", travel=180.0, max_rpm=20.0, trials=6, apply=True),
        on_note=lambda e: angles.append(sim.controllers[0].servo.motor.angle) if isinstance(e, TrialSample) else None,
    )
    assert len(result.trials) == 6 and result.best is not None
    assert all(t.figures is not None for t in result.trials if not t.aborted)
    assert angles and max(abs(a - home) for a in angles) <= 180.0
    s = sim.controllers[0].settings
    assert (s.speed_kp, s.speed_ki, s.speed_kd) == result.best.gains


def test_sim_bus_helper_is_the_one_used() -> None:
    assert callable(sim_bus)


def test_no_frame_reaches_the_controller_inside_its_eeprom_busy_time(make_sim_bus: Build) -> None:
    """Every gains write, control on/off and read-back waits out the busy window: a controller as
    slow as the window it is given never ignores a frame of the tune."""
    sim, bus = make_sim_bus([1], baud=115200, resolution=1024, eeprom_time=0.3, busy_window=0.3)
    sim.controllers[0].set_plant(Plant(inertia=3.0))
    motor = bus.motor(1)
    motor.set("position-kp", 200)  # aborted trials too: release, hold, gains back
    result = bus.run(motor.procedures.tune("position", travel=20.0, max_current=1.5, trials=8))
    assert len(result.trials) == 8
    assert sim.controllers[0].frames_ignored_busy == 0


def test_async_motor_tune(make_sim_bus: Build) -> None:
    import asyncio

    from nurimc import AsyncBus
    from nurimc.transport import SerialTransport

    sim, _ = on_plant(make_sim_bus, Plant(inertia=3.0))
    clock = sim.virtual
    assert clock is not None

    async def main() -> Any:
        bus = AsyncBus(SerialTransport(sim.open_serial(baudrate=115200), "sim://", latency=0.002), clock=clock)
        try:
            return await bus.motor(1).tune(goal="no-overshoot", trials=5, apply=True)
        finally:
            await bus.close()

    result = asyncio.run(main())
    assert len(result.trials) == 5 and result.applied and result.best is not None
    assert gains_on(sim) == result.best.gains


def test_one_missed_reading_is_asked_again_two_in_a_row_stop_the_tune(make_sim_bus: Build) -> None:
    from nurimc.errors import NoAnswer

    for misses, finishes in (({30}, True), ({30, 31}, False)):
        sim, bus = on_plant(make_sim_bus, Plant(inertia=3.0))
        procedures = bus.motor(1).procedures
        real = procedures.read_state
        calls = [0]

        def flaky(real: Any = real, calls: list[int] = calls, misses: set[int] = misses) -> Any:
            calls[0] += 1
            if calls[0] in misses:
                raise NoAnswer("request_position", 1, 115200, 3)
            return (yield from real())

        procedures.read_state = flaky  # type: ignore[method-assign]
        if finishes:
            result = bus.run(procedures.tune("position", trials=4))
            assert len(result.trials) == 4
        else:
            with pytest.raises(TuneStopped, match=r"no answer from ID 1.*restored the starting gains") as info:
                bus.run(procedures.tune("position", trials=4))
            assert info.value.restored
        assert gains_on(sim) == START


def test_a_reading_too_coarse_for_the_step_is_refused_before_anything_is_written(make_sim_bus: Build) -> None:
    sim, bus = make_sim_bus([1], baud=115200)  # the document's factory resolution 4: 22.5° steps
    controller = sim.controllers[0]
    angle = controller.servo.motor.angle
    coarse = r"reads its position in 22\.5° steps \(resolution 4 encoder pulses, ratio 1\)"
    with pytest.raises(TuneRefused, match=coarse):
        bus.motor(1).tune()
    assert controller.busy_until < 0  # no settings command reached it (each one starts its busy time)
    assert controller.servo.motor.angle == angle
    assert gains_on(sim) == START
