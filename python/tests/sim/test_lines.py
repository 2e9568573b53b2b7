"""Simulated controllers of the vendor's other product lines, driven with frames built by hand
from the layouts of the vendor's libraries (shared/vendor/product-lines.md §3-§4), on a fake
clock: what each line obeys and answers, and the vendor's ROS 2 driver stopping its wheels."""

from __future__ import annotations

import logging

import pytest

from nurimc.core.clock import VirtualClock
from nurimc.sim import SimBus

from .fakebus import FakePort, fake_bus
from .wirehelp import frame, u16


def answer(port: FakePort, ident: int, mode: int, size: int) -> bytes | None:
    """Send request `mode` and return the answer's data if a frame of mode + 0x30 and `size` came."""
    port.reset_input_buffer()
    port.write(frame(ident, mode))
    raw = port.read(64)
    for _ in range(20):  # up to 0.1 s of virtual time: an answer may wait for the one before it
        if len(raw) >= size + 4:
            break
        port.sleep(0.005)
        raw += port.read(64)
    if len(raw) != size + 4 or raw[:3] != bytes([0xFF, 0xFE, ident]) or raw[3] != size or raw[5] != mode + 0x30:
        return None
    assert raw[4] == ~(sum(raw[2:4]) + sum(raw[5:])) & 0xFF
    return raw[6:]


def speed_rpm(data: bytes) -> float:
    """Signed RPM from the data of a speed feedback answer (direction, speed 0.1 RPM, ...)."""
    value = int.from_bytes(data[1:3], "big") / 10
    return -value if data[0] else value


def run_for(port: FakePort, seconds: float) -> None:
    for _ in range(round(seconds / 0.02)):
        port.sleep(0.02)


def test_rsa_speaks_its_own_table() -> None:
    _, port = fake_bus([7], product="rsa")
    assert answer(port, 7, 0xA6, 4) == u16(10)  # A6 -> D6: RSA's ratio (MC's A6 is rated speed)
    port.write(frame(7, 0x09, u16(100)))  # 09: RSA set ratio 10:1 (MC's 09 is rated speed)
    assert answer(port, 7, 0xA6, 4) == u16(100)
    assert answer(port, 7, 0xA8, 3) == bytes([0])  # A8 -> D8: RSA's position mode (MC's A8 is ratio)
    port.write(frame(7, 0x0B, bytes([1])))  # 0B: RSA position mode relative (MC's 0B is ratio)
    assert answer(port, 7, 0xA8, 3) == bytes([1])
    port.write(frame(7, 0x0A, bytes([1])))  # 0A: RSA control off
    assert answer(port, 7, 0xA7, 3) == bytes([1])  # A7 -> D7: control
    assert answer(port, 7, 0xAB, 3) is None  # MC's control direction: no such RSA request


def test_rsa_moves_with_the_shared_motion_codes() -> None:
    _, port = fake_bus([7], product="rsa")
    port.write(frame(7, 0x01, bytes([0]) + u16(9000) + u16(600)))  # CCW to 90 deg at 60 RPM
    run_for(port, 1.0)
    data = answer(port, 7, 0xA1, 8)
    assert data is not None and abs(int.from_bytes(data[1:3], "big") / 100 - 90) < 2


def test_rsavw_echo_and_absolute_encoder() -> None:
    _, port = fake_bus([3], product="rsavw")
    assert answer(port, 3, 0xAA, 3) == bytes([0])  # AA -> DA: echo off
    port.write(frame(3, 0x0E, bytes([1])))  # 0E: echo on (01 on, 00 off)
    assert answer(port, 3, 0xAA, 3) == bytes([1])
    port.write(frame(3, 0x01, bytes([0]) + u16(9000) + u16(600)))
    run_for(port, 1.0)
    feedback = answer(port, 3, 0xA1, 8)
    data = answer(port, 3, 0xA9, 5)  # A9 -> D9: direction, absolute position in 0.01 deg
    assert feedback is not None and data is not None and len(data) == 3
    assert data[1:3] == feedback[1:3] and int.from_bytes(data[1:3], "big") > 0  # the same angle, within a turn


def test_sm_c_sharp_table_ramped_speed_and_set_id() -> None:
    _, port = fake_bus([9], product="sm")  # a simulated "sm" speaks the C# table
    assert answer(port, 9, 0xA4, 4) == u16(10)  # A4 -> D4: SM's ratio, 4 bytes
    port.write(frame(9, 0x01, bytes([1]) + u16(1000) + bytes([5])))  # 01: CW 100 RPM in 0.5 s
    run_for(port, 1.0)
    data = answer(port, 9, 0xA1, 8)  # A1 -> D1: SM's speed feedback
    assert data is not None and speed_rpm(data) == pytest.approx(-100, abs=2)
    port.write(frame(9, 0x03, bytes([4])))  # 03: set ID 4 under the C# table
    port.sleep(0.1)
    assert answer(port, 4, 0xA0, 2) == b""
    assert answer(port, 9, 0xA0, 2) is None


def test_sm_readme_table_ramped_speed_on_03() -> None:
    _, port = fake_bus([9], product="sm-readme")
    port.write(frame(9, 0x03, bytes([0]) + u16(600) + bytes([2])))  # README 03: CCW 60 RPM in 0.2 s
    run_for(port, 1.0)
    data = answer(port, 9, 0xA1, 8)
    assert data is not None and speed_rpm(data) == pytest.approx(60, abs=2)
    assert answer(port, 9, 0xA6, 3) is not None  # A6 -> D6: firmware, README table only
    assert answer(port, 9, 0xA0, 2) == b""  # still ID 9: 03 was no "set ID" here


def test_sa_open_loop_drives_and_duty_zero_lets_go() -> None:
    bus, port = fake_bus([2], product="sa")
    port.write(frame(2, 0x11, bytes([0]) + u16(5000)))  # 11: open loop, CCW, 50 %
    run_for(port, 1.0)
    data = answer(port, 2, 0xA2, 8)
    assert data is not None and speed_rpm(data) > 100
    port.write(frame(2, 0x11, bytes([0]) + u16(0)))  # duty 0: the bench author's stop (no drive)
    port.sleep(0.1)
    motor = bus.controller(2).servo.motor
    assert motor.current == 0.0
    coasting = motor.speed
    run_for(port, 1.0)
    assert 0 <= motor.speed < coasting  # coasting down, not driven


def test_mixed_bus_each_line_reads_its_own_bytes(caplog: pytest.LogCaptureFixture) -> None:
    bus = SimBus(clock=VirtualClock(), eeprom_time=0.0)
    bus.add_controller(1, 9600, "mc")
    bus.add_controller(7, 9600, "rsa")
    port = FakePort(bus, bus._clock)  # type: ignore[arg-type]
    caplog.set_level(logging.DEBUG, logger="nurimc.sim")
    port.write(frame(7, 0x0C, b""))  # RSA 0C: position reset (MC 0C would be control on/off)
    port.write(frame(1, 0x0C, bytes([1])))  # MC control off
    assert answer(port, 1, 0xA9, 3) == bytes([1])  # MC control: off
    assert answer(port, 7, 0xA7, 3) == bytes([0])  # RSA control: still on
    assert "RsaResetPosition(id=7)" in caplog.text


def vendor_driver_wheels(speed_zero: str | None) -> tuple[SimBus, FakePort]:
    """The vendor's ROS 2 driver (product-lines.md §7): IDs 0 and 1 at 38,400 bps, turned with
    03 frames, polled with A2."""
    clock = VirtualClock()
    bus = SimBus(clock=clock, eeprom_time=0.0, speed_zero=speed_zero)
    for wheel in (0, 1):
        bus.add_controller(wheel, 38400, "mc")
    port = FakePort(bus, clock, baud=38400)
    for wheel, direction in ((0, 0), (1, 1)):
        port.write(frame(wheel, 0x03, bytes([direction]) + u16(1000) + bytes([1])))  # 100 RPM in 0.1 s
    run_for(port, 0.5)
    return bus, port


def test_the_vendor_ros2_driver_stops_its_wheels_against_the_default_simulator() -> None:
    _, port = vendor_driver_wheels(None)
    for wheel in (0, 1):
        data = answer(port, wheel, 0xA2, 8)
        assert data is not None and abs(speed_rpm(data)) > 90
    for wheel in (0, 1):  # cmd_vel 0 0: speed 0, arrival 0.1 s, to both wheels
        port.write(frame(wheel, 0x03, bytes([0]) + u16(0) + bytes([1])))
    run_for(port, 0.5)
    for wheel in (0, 1):
        data = answer(port, wheel, 0xA2, 8)
        assert data is not None and speed_rpm(data) == 0


def test_speed_zero_ignore_is_the_documents_strict_reading(caplog: pytest.LogCaptureFixture) -> None:
    _, port = vendor_driver_wheels("ignore")
    caplog.set_level(logging.DEBUG, logger="nurimc.sim")
    port.write(frame(0, 0x03, bytes([0]) + u16(0) + bytes([1])))
    run_for(port, 0.5)
    data = answer(port, 0, 0xA2, 8)
    assert data is not None and abs(speed_rpm(data)) > 90  # still turning
    assert "speed 0 is outside the document's range" in caplog.text


def test_speed_zero_decelerates_over_the_arrival_time() -> None:
    _, port = vendor_driver_wheels(None)
    port.write(frame(0, 0x03, bytes([0]) + u16(0) + bytes([20])))  # stop over 2.0 s
    run_for(port, 1.0)
    data = answer(port, 0, 0xA2, 8)
    assert data is not None and 20 < abs(speed_rpm(data)) < 80  # half way down
    run_for(port, 1.5)
    data = answer(port, 0, 0xA2, 8)
    assert data is not None and speed_rpm(data) == 0
