"""Multi-turn tracking against the simulated shaft (virtual time, in-process simulator).

The library's continuous position is compared with the simulator's true shaft angle after
random runs at speeds up to the rated 3,000 RPM, read at random gaps, ended by an E-STOP
(control off: the motor coasts): every reading is either within the wire's reach of the
truth, or marked uncertain. Never silently wrong."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurimc import Motor
from nurimc.sim import SimBus, SimController
from tests.client.simfixtures import sim_bus

RATED_RPM = 3000
ONE_DEGREE = 1.0


def _fine(sim: SimBus) -> SimController:
    controller = sim.controllers[0]
    controller.settings.resolution = 4096  # 0.022 deg steps: the comparison is about turns, not steps
    controller.apply_settings()
    return controller


def _truth(controller: SimController) -> float:
    return controller.servo.motor.angle * (-1.0 if controller.settings.direction else 1.0)


def _check(motor: Motor, controller: SimController, slack_s: float) -> tuple[bool, float]:
    """Read once; (uncertain, error in degrees) with the time the answer takes on the wire as slack."""
    state = motor.read_state()
    truth = _truth(controller)
    error = abs(state.position - truth)
    allowed = ONE_DEGREE + abs(controller.servo.motor.speed) * slack_s
    assert state.position_uncertain or error <= allowed, (state, truth)
    return state.position_uncertain, error


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    runs=st.lists(
        st.tuples(st.integers(-RATED_RPM, RATED_RPM).filter(lambda r: abs(r) >= 1), st.floats(0.05, 0.6)),
        min_size=1,
        max_size=3,
    ),
    gaps=st.lists(st.floats(0.001, 0.4), min_size=8, max_size=8),
)
def test_continuous_position_is_true_or_marked_uncertain(runs: list[tuple[int, float]], gaps: list[float]) -> None:
    sim, bus = sim_bus([1], baud=1_000_000)
    with bus:
        controller = _fine(sim)
        motor = bus.motor(1)
        motor.read_state()
        turn = 0
        for rpm, seconds in runs:
            motor.run(rpm, ramp_seconds=0.1)
            end = bus.clock.now() + seconds
            while bus.clock.now() < end:
                _check(motor, controller, 0.002)
                bus.clock.sleep(gaps[turn % len(gaps)])
                turn += 1
        motor.release()  # the E-STOP: control off, the motor coasts
        while abs(controller.servo.motor.speed) > 0.0:
            _check(motor, controller, 0.002)
            bus.clock.sleep(gaps[turn % len(gaps)])
            turn += 1
        uncertain, error = _check(motor, controller, 0.0)
        assert uncertain or error <= ONE_DEGREE


def test_fast_polling_stays_certain_at_every_speed_and_through_an_estop() -> None:
    """Read every 20 ms (the console's rate with a few motors): 300, 1,500 and 3,000 RPM, then
    the E-STOP and the coast to rest, all certain and within 1 deg at rest."""
    for rpm in (300, 1500, 3000, -1500):
        sim, bus = sim_bus([1], baud=1_000_000)
        with bus:
            controller = _fine(sim)
            motor = bus.motor(1)
            motor.run(rpm, ramp_seconds=0.1)
            end = bus.clock.now() + 2.0
            while bus.clock.now() < end:
                assert not _check(motor, controller, 0.002)[0]
                bus.clock.sleep(0.02)
            state = motor.read_state()
            assert abs(state.speed - rpm) < 0.02 * abs(rpm), state  # signed, as run
            motor.release()
            while abs(controller.servo.motor.speed) > 0.0:
                assert not _check(motor, controller, 0.002)[0]
                bus.clock.sleep(0.02)
            uncertain, error = _check(motor, controller, 0.0)
            assert not uncertain and error <= ONE_DEGREE
            assert abs(_truth(controller)) > 655.36  # it really went round more than once


def test_a_long_gap_at_speed_is_marked_uncertain_not_guessed_silently() -> None:
    """The issue's case: a second without readings while a motor turns at 1,500 RPM."""
    sim, bus = sim_bus([1], baud=1_000_000)
    with bus:
        controller = _fine(sim)
        motor = bus.motor(1)
        motor.run(1500, ramp_seconds=0.1)
        bus.clock.sleep(0.3)
        assert not motor.read_state().position_uncertain
        bus.clock.sleep(1.0)
        state = motor.read_state()
        assert state.position_uncertain
        assert motor.read_state().position_uncertain  # it stays so: the turns are lost
        motor.procedures.tracker.reset()
        assert not motor.read_state().position_uncertain
        del controller


def test_minus_45_rpm_reads_minus_45() -> None:
    sim, bus = sim_bus([1], baud=115_200)
    with bus:
        _fine(sim)
        motor = bus.motor(1)
        motor.run(-45, ramp_seconds=0.1)
        bus.clock.sleep(1.0)
        first = motor.read_state()  # no trend yet: position feedback's speed has no sign
        assert first.speed == 45.0 and not first.speed_signed
        bus.clock.sleep(0.05)
        second = motor.read_state()
        assert second.speed == -45.0 and second.speed_signed  # the trend
        assert motor.read_speed() == -45.0
