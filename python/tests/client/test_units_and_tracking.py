"""Physical units, settings parsing, multi-turn tracking."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.procedures.multiturn import TurnTracker
from nurimc.procedures.settings import setting
from nurimc.protocol import FieldRangeError, units


def test_rounding_is_decimal_and_half_away_from_zero() -> None:
    assert units.degrees_to_wire(180.005) == 18001
    assert units.degrees_to_wire(180.004) == 18000
    assert units.rpm_to_wire(0.15) == 2
    assert units.from_wire(3, 0.1) == 0.3
    assert units.microseconds_to_wire(250) == 3  # 2.5 steps -> 3


def test_a_feedback_value_divided_by_its_steps_is_exactly_from_wire() -> None:
    # Motor.state_from divides (every reading comes through it); from_wire is the rule
    for raw in range(-65536, 65536):
        assert raw / 100 == units.from_wire(raw, 0.01) and raw / 10 == units.from_wire(raw, 0.1), raw


@pytest.mark.parametrize(
    ("name", "value", "raw"),
    [
        ("ratio", "12.5", 125),
        ("ratio", 10, 100),
        ("response-time", "300us", 3),
        ("response-time", "1.2ms", 12),
        ("direction", "cw", 1),
        ("control", "off", 1),
        ("position-mode", "relative", 1),
        ("position_kp", 200, 200),
        ("speed-rated-current", "2.5A", 25),
    ],
)
def test_settings_parse_physical_values(name: str, value: object, raw: int) -> None:
    assert setting(name).to_wire(value) == raw


def test_setting_errors_say_the_range() -> None:
    with pytest.raises(FieldRangeError, match=r"0\.1\.\.6553\.3 :1"):
        setting("ratio").to_wire(0)
    with pytest.raises(FieldRangeError, match="ccw or cw"):
        setting("direction").to_wire("up")
    with pytest.raises(KeyError, match="settings: position-kp"):
        setting("warp")


def test_tracker_unwraps_across_the_655_36_degree_wrap() -> None:
    tracker = TurnTracker()
    positions = [600.0, 650.0, 4.64, 54.64]  # counting up through the wrap (655.36)
    out = [tracker.update(p) for p in positions]
    assert out == pytest.approx([600.0, 650.0, 660.0, 710.0])
    assert tracker.update(-10.0) == pytest.approx(645.36)  # a reading of -10 is the same counter as 645.36


def test_tracker_follows_negative_motion() -> None:
    tracker = TurnTracker()
    assert [tracker.update(p) for p in (10.0, -20.0, -300.0)] == pytest.approx([10.0, -20.0, -300.0])


def test_tracker_uses_the_speed_and_the_time_to_count_whole_turns() -> None:
    """At 3,000 RPM (18,000 deg/s) read every 50 ms the shaft turns 900 deg between readings:
    the shortest way would say 244.64 deg; the speed says 900."""
    tracker = TurnTracker()
    wrap = 655.36
    truth = [18_000.0 * 0.05 * i for i in range(6)]
    for i, angle in enumerate(truth):
        device = angle % wrap
        got = tracker.step(device, 18_000.0, i * 0.05)
        assert got.position == pytest.approx(angle)
        assert not got.uncertain
    assert tracker.sign == 1  # position feedback's speed had no sign: the trend gave it


def test_tracker_marks_a_gap_the_speed_cannot_decide_and_keeps_the_mark() -> None:
    tracker = TurnTracker()
    tracker.step(0.0, 9_000.0, 0.0)
    tracker.step(90.0, 9_000.0, 0.01)
    step = tracker.step(123.0, 9_000.0, 1.01)  # a second at 1,500 RPM: any of many turns
    assert step.uncertain and tracker.guesses == 1
    assert tracker.step(213.0, 9_000.0, 1.02).uncertain  # the turns stay unknown
    tracker.reset()
    assert not tracker.step(10.0, 0.0, 2.0).uncertain


def test_tracker_signed_speed_decides_the_direction() -> None:
    tracker = TurnTracker()
    tracker.step(0.0, -270.0, 0.0, signed=True)  # -45 RPM
    step = tracker.step(-2.7, -270.0, 0.01, signed=True)
    assert step.position == pytest.approx(-2.7) and step.speed == -270.0 and tracker.sign == -1


def test_travel_range_bounds_what_a_shaft_can_do() -> None:
    from nurimc.procedures.multiturn import travel_range

    assert travel_range(100.0, 100.0, 0.1, 1000.0, 10_000.0) == pytest.approx((7.5, 12.5))
    assert travel_range(0.0, 1000.0, 0.1, 1000.0, 10_000.0) is None  # needs 10,000 deg/s^2
    lo, hi = travel_range(0.0, 0.0, 1.0, 1000.0, 100.0)  # type: ignore[misc]
    assert hi == pytest.approx(90.0) and lo == pytest.approx(-90.0)  # capped at the top speed


def test_a_motor_at_rest_with_no_command_across_a_long_gap_has_not_moved() -> None:
    tracker = TurnTracker()
    tracker.step(100.0, 0.0, 0.0, commands=3)
    tracker.step(100.0, 0.0, 0.02, commands=3)  # at rest twice: it stays so until told otherwise
    step = tracker.step(100.01, 0.0, 5.0, commands=3)  # polling paused 5 s (a settings write, a read-back)
    assert step.position == 100.01 and not step.uncertain
    # a command went out in the gap: the motor may have turned any number of times and stopped
    assert tracker.step(100.0, 0.0, 10.0, commands=4).uncertain


def test_a_motor_seen_at_rest_once_may_have_been_starting_a_move() -> None:
    """At rest once (a move just sent, not begun), then a long gap: not taken for "stayed put"."""
    tracker = TurnTracker()
    tracker.step(0.0, 0.0, 0.0, commands=1)
    assert tracker.step(64.64, 0.0, 2.0, commands=1).uncertain  # 720 deg later, or 64.64, or ...


@settings(max_examples=300, deadline=None)
@given(
    speeds=st.lists(st.floats(-18_000.0, 18_000.0), min_size=2, max_size=6),
    gaps=st.lists(st.floats(0.001, 0.6), min_size=5, max_size=40),
    start=st.floats(-2000.0, 2000.0),
    signed=st.booleans(),
)
def test_unwrapping_is_true_or_marked_uncertain(
    speeds: list[float], gaps: list[float], start: float, signed: bool
) -> None:
    """A shaft whose speed ramps (at most 50,000 deg/s^2) between random targets up to the rated
    3,000 RPM, read at random gaps as the device reports it: the continuous position is the
    shaft's, or marked uncertain. Never silently wrong."""
    wrap = 655.36
    accel, dt = 50_000.0, 0.0005
    tracker = TurnTracker()
    angle, speed, t, target_index, read_at = start, 0.0, 0.0, 0, 0.0
    gap_index = 0

    def device(a: float) -> float:
        magnitude = round(abs(a), 2) % wrap
        return -magnitude if a < 0 else magnitude

    def speed_reading(v: float) -> float:
        return round(v / 0.6) * 0.6 if signed else round(abs(v) / 0.6) * 0.6

    tracker.step(device(angle), speed_reading(speed), t, signed=signed)
    offset = angle - device(angle)  # the count starts at the first reading (whole turns before it are unknown)
    while gap_index < len(gaps):
        goal = speeds[target_index % len(speeds)]
        change = max(-accel * dt, min(accel * dt, goal - speed))
        speed += change
        angle += speed * dt
        t += dt
        if abs(goal - speed) < 1e-9:
            target_index += 1
        if t - read_at >= gaps[gap_index]:
            read_at = t
            gap_index += 1
            step = tracker.step(device(angle), speed_reading(speed), t, signed=signed)
            assert step.uncertain or abs(step.position + offset - angle) < 0.05, (step, angle)
