"""Physical units, settings parsing, multi-turn tracking."""

from __future__ import annotations

import pytest

from nurimc.multiturn import TurnTracker
from nurimc.protocol import FieldRangeError, units
from nurimc.settings import setting


def test_rounding_is_decimal_and_half_away_from_zero() -> None:
    assert units.degrees_to_wire(180.005) == 18001
    assert units.degrees_to_wire(180.004) == 18000
    assert units.rpm_to_wire(0.15) == 2
    assert units.from_wire(3, 0.1) == 0.3
    assert units.microseconds_to_wire(250) == 3  # 2.5 steps -> 3


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
