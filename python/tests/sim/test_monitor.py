"""The monitor endpoint hears both directions; -v says why a frame was not taken."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import serial

from nurimc.protocol import make
from nurimc.protocol.sniff import SniffedFrame, Sniffer
from nurimc.sim import SimBus

from .fakebus import fake_bus
from .wirehelp import frame


def _heard(port: serial.SerialBase) -> list[str]:
    heard = Sniffer().feed(port.read(4096), 0.0)
    return [f"{h.direction} {h.event.message.name}" for h in heard if isinstance(h.event, SniffedFrame)]


def test_monitor_hears_requests_commands_and_answers() -> None:
    bus, host = fake_bus([1])
    monitor = bus.open_serial(timeout=0, monitor=True)
    host.write(make("request_position", 1).encode())
    host.write(make("position_speed", 1, direction=0, position=9000, speed=100).encode())
    assert host.read(100)  # the host got its answer ...
    assert _heard(monitor) == [  # ... and the monitor heard all of it, in bus order
        "host -> id 1 request_position",
        "id 1 -> host position_feedback",
        "host -> id 1 position_speed",
    ]


def test_monitor_at_another_rate_hears_garbage_and_plain_hosts_hear_no_requests() -> None:
    bus, host = fake_bus([1])
    other_host = bus.open_serial(timeout=0)
    slow_monitor = bus.open_serial(baudrate=19200, timeout=0, monitor=True)
    host.write(make("request_ping", 1).encode())
    assert other_host.read(100) == make("ping", 1).encode()  # answers only, as before
    assert _heard(slow_monitor) == [] and slow_monitor.in_waiting == 0  # read already; it was garbage


def test_monitor_pty_with_plain_pyserial(tmp_path: Path) -> None:
    bus = SimBus(eeprom_time=0.0)
    bus.add_controller(1)
    host_end = bus.serve_pty(link=str(tmp_path / "host"))
    monitor_end = bus.serve_monitor(link=str(tmp_path / "monitor"))
    try:
        with (
            serial.Serial(str(tmp_path / "host"), 9600, timeout=0.5) as host,
            serial.Serial(str(tmp_path / "monitor"), 9600, timeout=0.3) as monitor,
        ):
            host.write(frame(1, 0xA1))
            answer = host.read(12)
            assert len(answer) == 12
            seen = b""
            while len(seen) < 18:
                chunk = monitor.read(64)
                if not chunk:
                    break
                seen += chunk
            assert seen == frame(1, 0xA1) + answer  # the request, then the answer the host got
    finally:
        host_end.stop()
        monitor_end.stop()
        bus.close()


def test_verbose_log_says_why_frames_were_not_taken(caplog: pytest.LogCaptureFixture) -> None:
    _, host = fake_bus([1], eeprom_time=1.0, speed_zero="ignore")  # the document's reading of speed 0
    caplog.set_level(logging.DEBUG, logger="nurimc.sim")
    bad = bytearray(frame(1, 0xA0))
    bad[4] ^= 1
    host.write(bytes(bad))  # bad checksum
    host.write(b"\xff\xfe\x01\x02\x00\x55")  # unknown mode
    host.write(b"\xff\xfe\x01\x03\xfb\xa0\x00")  # wrong size for a ping request
    host.write(frame(7, 0xA0))  # nobody has ID 7
    host.write(frame(1, 0x01, bytes([0, 0, 100, 0, 0])))  # speed 0
    host.write(frame(1, 0x08, bytes([3])))  # a settings write: busy for 1 s
    host.write(frame(1, 0xA0))
    host.inner.baudrate = 57600
    host.write(frame(1, 0xA0))  # nobody listens at 57600
    text = caplog.text
    for reason in (
        "bad checksum",
        "unknown mode 0x55",
        "wrong size 3 for request_ping",
        "no controller has ID 7",
        "speed 0 is outside",
        "busy writing settings",
        "no controller listens at that rate",
    ):
        assert reason in text, reason


def test_verbose_log_says_motion_is_dropped_while_control_is_off(caplog: pytest.LogCaptureFixture) -> None:
    bus, host = fake_bus([1])
    caplog.set_level(logging.DEBUG, logger="nurimc.sim")
    host.write(frame(1, 0x0C, bytes([1])))  # control off
    host.write(frame(1, 0x03, bytes([0, 0x03, 0xE8, 10])))  # run at 100 RPM: not obeyed
    host.clock.t += 0.5
    bus.advance()
    assert "ignores AccelSpeed(id=1, direction=0, speed=1000, arrival_time=10): control is off" in caplog.text
    assert bus.controller(1).servo.motor.speed == 0.0


def test_verbose_log_names_the_rate_of_an_id_addressed_at_the_wrong_one(caplog: pytest.LogCaptureFixture) -> None:
    bus = SimBus()
    bus.add_controller(1, 9600)
    bus.add_controller(2, 57600)
    caplog.set_level(logging.DEBUG, logger="nurimc.sim")
    host = bus.open_serial(baudrate=9600, timeout=0.1)
    host.write(frame(2, 0xA0))
    assert host.read(6) == b""
    assert "no controller has ID 2 at this rate (wrong rate: ID 2 listens at 57600 bps)" in caplog.text
    bus.close()
