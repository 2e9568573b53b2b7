"""Motion commands and their effect on the feedback, through the pseudo-terminal."""

from __future__ import annotations

import time
from collections.abc import Callable

import serial

from .conftest import Pty
from .wirehelp import ask, command, position, u16


def fine_encoder(port: serial.Serial) -> None:
    command(port, 0, "set_resolution", u16(1000))  # 4000 counts per turn: 0.09 deg steps
    assert ask(port, 0, 0xA7) == u16(1000)


def settle(port: serial.Serial, target: float, tolerance: float = 0.5, patience: float = 5.0) -> list[float]:
    """Poll the position until it stays within tolerance of target; return the trace."""
    trace: list[float] = []
    deadline = time.monotonic() + patience
    while time.monotonic() < deadline:
        trace.append(position(port, 0))
        if len(trace) >= 3 and all(abs(p - target) <= tolerance for p in trace[-3:]):
            return trace
        time.sleep(0.02)
    raise AssertionError(f"did not settle at {target}: {trace[-10:]}")


def test_position_speed_moves_over_time_and_settles(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    fine_encoder(port)
    assert position(port, 0) == 0.0
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(600))  # CCW 90 deg at 60 RPM (0.25 s)
    trace = settle(port, 90.0)
    moving = [p for p in trace if 1.0 < p < 89.0]
    assert moving, f"no intermediate positions: {trace}"
    assert trace == sorted(trace) or max(trace) < 95  # goes there, at most a small overshoot
    data = ask(port, 0, 0xA1)
    assert data is not None and data[0] == 0 and int.from_bytes(data[3:5], "big") <= 10  # (nearly) stopped


def test_cw_is_negative_and_reported_with_direction_flag(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    fine_encoder(port)
    command(port, 0, "position_speed", bytes([1]) + u16(4500) + u16(1200))  # CW 45 deg
    settle(port, -45.0)
    data = ask(port, 0, 0xA1)
    assert data is not None and data[0] == 1 and abs(int.from_bytes(data[1:3], "big") - 4500) <= 50


def test_accel_position_arrives_in_time(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    fine_encoder(port)
    start = time.monotonic()
    command(port, 0, "accel_position", bytes([0]) + u16(18000) + bytes([5]))  # 180 deg in 0.5 s
    trace = settle(port, 180.0)
    assert any(5.0 < p < 175.0 for p in trace), trace  # seen on the way
    assert time.monotonic() - start >= 0.4  # it took its time


def test_accel_speed_ramps_then_control_off_coasts(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    command(port, 0, "accel_speed", bytes([0]) + u16(500) + bytes([3]))  # 50 RPM in 0.3 s
    time.sleep(0.6)
    data = ask(port, 0, 0xA2)
    assert data is not None and data[0] == 0
    assert abs(int.from_bytes(data[1:3], "big") - 500) <= 15
    command(port, 0, "set_control", bytes([1]))  # release
    time.sleep(1.0)
    data = ask(port, 0, 0xA2)
    assert data is not None and int.from_bytes(data[1:3], "big") == 0  # friction stopped it
    assert int.from_bytes(data[5:6], "big") == 0  # no current when released


def test_relative_mode_adds_steps(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    fine_encoder(port)
    command(port, 0, "set_position_mode", bytes([1]))
    assert ask(port, 0, 0xAA) == bytes([1])
    for expected in (30.0, 60.0):
        command(port, 0, "position_speed", bytes([0]) + u16(3000) + u16(1200))
        settle(port, expected)


def test_control_direction_flips_sense(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty()
    port = pty.open()
    fine_encoder(port)
    command(port, 0, "set_direction", bytes([1]))
    assert ask(port, 0, 0xAB) == bytes([1])
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(1200))  # "CCW" 90 deg
    settle(port, 90.0)
    assert pty.bus.controllers[0].servo.motor.angle < -80  # physically the other way round


def test_position_reset_zeroes(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    fine_encoder(port)
    command(port, 0, "position_speed", bytes([0]) + u16(9000) + u16(1200))
    settle(port, 90.0)
    command(port, 0, "reset_position")
    settle(port, 0.0, tolerance=0.1)


def test_gains_change_the_step_response(make_pty: Callable[..., Pty]) -> None:
    """A soft position gain lags the reference visibly more than the default."""
    lag = []
    for kp in (50, 3):
        port = make_pty().open()
        fine_encoder(port)
        command(port, 0, "position_gains", bytes([kp, 0, 10, 50]))
        assert ask(port, 0, 0xA3) == bytes([kp, 0, 10, 50])
        command(port, 0, "accel_position", bytes([0]) + u16(9000) + bytes([2]))  # 90 deg in 0.2 s
        time.sleep(0.3)
        lag.append(90.0 - position(port, 0))
    assert lag[1] > lag[0] + 5, lag
