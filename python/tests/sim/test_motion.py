"""Motion commands and their effect on the feedback, on a fake clock (no test sleeps)."""

from __future__ import annotations

import pytest

from nurimc.sim.motor import ACCEL_PER_AMP

from .fakebus import FakePort, fake_bus
from .wirehelp import ask, command, position, u16


def fine_encoder(port: FakePort, ident: int = 0) -> None:
    command(port, ident, "set_resolution", u16(1000))  # 4000 counts per turn: 0.09 deg steps
    assert ask(port, ident, 0xA7) == u16(1000)


def settle(port: FakePort, target: float, tolerance: float = 0.5, patience: float = 5.0) -> list[float]:
    """Poll the position until it stays within tolerance of target; return the trace."""
    trace: list[float] = []
    deadline = port.clock.t + patience
    while port.clock.t < deadline:
        trace.append(position(port, 0))
        if len(trace) >= 3 and all(abs(p - target) <= tolerance for p in trace[-3:]):
            return trace
        port.sleep(0.02)
    raise AssertionError(f"did not settle at {target}: {trace[-10:]}")


def arrival_time(port: FakePort, target: float, tolerance: float, patience: float) -> float:
    """Seconds until the position is within tolerance of target and stays there for 0.3 s."""
    start, arrived = port.clock.t, None
    while port.clock.t - start < patience:
        p = position(port, 0)
        if abs(p - target) <= tolerance:
            arrived = port.clock.t if arrived is None else arrived
            if port.clock.t - arrived >= 0.3:
                return arrived - start
        else:
            arrived = None
        port.sleep(0.01)
    raise AssertionError(f"did not arrive at {target} within {patience} s (at {position(port, 0)})")


def test_position_speed_moves_over_time_and_settles() -> None:
    _, port = fake_bus()
    fine_encoder(port)
    assert position(port, 0) == 0.0
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(600))  # CCW 90 deg at 60 RPM (0.25 s)
    trace = settle(port, 90.0)
    moving = [p for p in trace if 1.0 < p < 89.0]
    assert moving, f"no intermediate positions: {trace}"
    assert max(trace) < 95  # goes there, at most a small overshoot
    data = ask(port, 0, 0xA1)
    assert data is not None and data[0] == 0 and int.from_bytes(data[3:5], "big") <= 10  # (nearly) stopped


def test_cw_is_negative_and_reported_with_direction_flag() -> None:
    _, port = fake_bus()
    fine_encoder(port)
    command(port, 0, "position_speed", bytes([1]) + u16(4500) + u16(1200))  # CW 45 deg
    settle(port, -45.0)
    data = ask(port, 0, 0xA1)
    assert data is not None and data[0] == 1 and abs(int.from_bytes(data[1:3], "big") - 4500) <= 50


def test_accel_position_arrives_in_time() -> None:
    _, port = fake_bus()
    fine_encoder(port)
    start = port.clock.t
    command(port, 0, "accel_position", bytes([0]) + u16(18000) + bytes([5]))  # 180 deg in 0.5 s
    trace = settle(port, 180.0)
    assert any(5.0 < p < 175.0 for p in trace), trace  # seen on the way
    assert port.clock.t - start >= 0.4  # it took its time


def test_accel_speed_ramps_then_control_off_coasts() -> None:
    _, port = fake_bus()
    command(port, 0, "accel_speed", bytes([0]) + u16(500) + bytes([3]))  # 50 RPM in 0.3 s
    port.sleep(0.6)
    data = ask(port, 0, 0xA2)
    assert data is not None and data[0] == 0
    assert abs(int.from_bytes(data[1:3], "big") - 500) <= 15
    command(port, 0, "set_control", bytes([1]))  # release
    port.sleep(1.0)
    data = ask(port, 0, 0xA2)
    assert data is not None and int.from_bytes(data[1:3], "big") == 0  # friction stopped it
    assert int.from_bytes(data[5:6], "big") == 0  # no current when released


def test_relative_mode_adds_steps() -> None:
    _, port = fake_bus()
    fine_encoder(port)
    command(port, 0, "set_position_mode", bytes([1]))
    assert ask(port, 0, 0xAA) == bytes([1])
    for expected in (30.0, 60.0):
        command(port, 0, "position_speed", bytes([0]) + u16(3000) + u16(1200))
        settle(port, expected)


def test_control_direction_flips_sense() -> None:
    bus, port = fake_bus()
    fine_encoder(port)
    command(port, 0, "set_direction", bytes([1]))
    assert ask(port, 0, 0xAB) == bytes([1])
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(1200))  # "CCW" 90 deg
    settle(port, 90.0)
    assert bus.controllers[0].servo.motor.angle < -80  # physically the other way round


def test_position_reset_zeroes() -> None:
    _, port = fake_bus()
    fine_encoder(port)
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(1200))
    settle(port, 90.0)
    command(port, 0, "reset_position")
    settle(port, 0.0, tolerance=0.1)


def test_gains_change_the_step_response() -> None:
    """A soft position gain lags the reference visibly more than the default."""
    lag = []
    for kp in (50, 3):
        _, port = fake_bus()
        fine_encoder(port)
        command(port, 0, "position_gains", bytes([kp, 0, 10, 50]))
        assert ask(port, 0, 0xA3) == bytes([kp, 0, 10, 50])
        command(port, 0, "accel_position", bytes([0]) + u16(9000) + bytes([2]))  # 90 deg in 0.2 s
        port.sleep(0.3)
        lag.append(90.0 - position(port, 0))
    assert lag[1] > lag[0] + 5, lag


# --- gearboxes and rated currents ----------------------------------------------------------------


def _geared(ratio: float, amps: float, resolution: int = 4) -> FakePort:
    _, port = fake_bus()
    command(port, 0, "set_ratio", u16(round(ratio * 10)))
    command(port, 0, "set_resolution", u16(resolution))
    command(port, 0, "position_gains", bytes([50, 0, 10, round(amps * 10)]))
    command(port, 0, "speed_gains", bytes([30, 10, 0, round(amps * 10)]))
    assert ask(port, 0, 0xA8) == u16(round(ratio * 10))
    return port


def test_a_212_to_1_motor_moves_90_degrees_at_10_rpm_within_3_s() -> None:
    """The issue's case: the geared motor used to stay at 0.0 with the current at its limit."""
    for amps in (5.0, 1.8):  # the default rated current and a small motor's
        port = _geared(212, amps)
        command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(100))  # 90 deg at 10.0 RPM
        assert arrival_time(port, 90.0, tolerance=0.5, patience=3.0) < 3.0


@pytest.mark.parametrize("ratio", [1, 10, 60, 167, 212, 500, 1000])
@pytest.mark.parametrize("amps", [1.0, 5.0, 25.4])
def test_any_ratio_and_rated_current_starts_and_tracks(ratio: int, amps: float) -> None:
    """90 deg at 10 RPM (or the top speed the rated 3000 RPM allows behind the gearbox) arrives
    in about the travel time plus the time to speed up and slow down at half the current."""
    port = _geared(ratio, amps, resolution=1000)
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(100))
    speed = min(60.0, 3000 * 6.0 / ratio)  # deg/s
    accel = 0.5 * amps * ACCEL_PER_AMP / ratio  # deg/s^2 at the output, with half the current
    bound = 90.0 / speed + 2 * speed / accel + 0.6
    assert arrival_time(port, 90.0, tolerance=0.5, patience=bound) <= bound


@pytest.mark.parametrize("ratio", [1, 212, 1000])
def test_the_smallest_rated_current_still_starts_a_geared_motor(ratio: int) -> None:
    port = _geared(ratio, 0.1, resolution=1000)
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(100))
    port.sleep(1.0)
    assert position(port, 0) > 0.2


def test_a_geared_motor_holds_a_speed() -> None:
    port = _geared(212, 5.0)
    command(port, 0, "accel_speed", bytes([1]) + u16(100) + bytes([5]))  # CW 10 RPM in 0.5 s
    port.sleep(1.5)
    data = ask(port, 0, 0xA2)
    assert data is not None and data[0] == 1 and abs(int.from_bytes(data[1:3], "big") - 100) <= 3


@pytest.mark.parametrize("direction", [0, 1])
def test_an_absolute_target_is_for_the_wrapping_register(direction: int) -> None:
    # after more than a turn of the 655.36 deg register, a target equal to the reported position
    # holds the motor where it is (it does not drive back to the first turn), and a target is
    # reached by the way the register counts: the feedback then reads the target
    _, port = fake_bus()
    fine_encoder(port)
    command(port, 0, "accel_speed", bytes([direction]) + u16(1200) + bytes([1]))  # 120 RPM = 720 deg/s
    port.sleep(1.5)  # about 1000 deg: past the register's wrap
    command(port, 0, "accel_speed", bytes([direction]) + u16(1) + bytes([1]))  # nearly stopped
    port.sleep(1.0)
    reported = position(port, 0)
    assert 0 < abs(reported) < 655.36 and (reported < 0) == bool(direction)
    command(port, 0, "position_speed", bytes([direction]) + u16(round(abs(reported) * 100)) + u16(600))
    trace = []
    for _ in range(60):
        port.sleep(0.02)
        trace.append(position(port, 0))
    assert max(abs(p - reported) for p in trace) < 1.0, trace[::10]
    command(port, 0, "position_speed", bytes([direction]) + u16(10000) + u16(600))  # 100 deg, same side
    settle(port, -100.0 if direction else 100.0)
