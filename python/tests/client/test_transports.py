"""The library over real transports: a pseudo-terminal at all 18 rates, TCP, loop://, sim://."""

from __future__ import annotations

import errno
import time
from pathlib import Path

import pytest

from nurimc import Bus, NoAnswer, PortError
from nurimc.protocol import BAUD_RATES
from nurimc.sim import SimBus
from nurimc.transport.latency import estimate_latency
from nurimc.transport.serial_transport import _port_error


@pytest.mark.realtime
def test_every_rate_through_a_pseudo_terminal() -> None:
    sim = SimBus()
    for index, rate in enumerate(BAUD_RATES):
        sim.add_controller(id=index, baud=rate)
    endpoint = sim.serve_pty()
    try:
        with Bus.open(endpoint.path, baudrate=9600, retries=1) as bus:
            for index, rate in enumerate(BAUD_RATES):
                bus.baudrate = rate
                assert bus.motor(index).ping(), rate
            bus.baudrate = 9600
            with pytest.raises(NoAnswer, match="at 9600 bps"):
                bus.motor(17).ping()  # that controller listens at 1 Mbps only
    finally:
        endpoint.stop()
        sim.close()


@pytest.mark.realtime
def test_motion_over_the_pseudo_terminal() -> None:
    """End to end on the real clock: a pseudo-terminal served by the simulator's thread."""
    sim = SimBus()
    sim.add_controller(id=2, baud=115200)
    endpoint = sim.serve_pty()
    try:
        with Bus.open(endpoint.path, baudrate=115200) as bus:
            motor = bus.motor(2)
            motor.set("resolution", 1000)
            motor.move_to(120, rpm=300)
            end = time.monotonic() + 30
            while abs(motor.read_state().position - 120) > 0.5 and time.monotonic() < end:
                time.sleep(0.02)
            assert abs(motor.read_state().position - 120) <= 0.5
    finally:
        endpoint.stop()
        sim.close()


@pytest.mark.realtime
def test_socket_url() -> None:
    sim = SimBus()
    sim.add_controller(id=1)
    server = sim.serve_tcp(port=0)
    try:
        host, port = server.address
        with Bus.open(f"socket://{host}:{port}", baudrate=9600) as bus:
            assert bus.motor(1).get("rated-speed") == 3000
    finally:
        server.stop()
        sim.close()


def test_sim_url_and_loop_url() -> None:
    with Bus.open("sim://?ids=0,3&baud=9600") as bus:
        assert bus.motor(3).ping()
    with Bus.open("loop://", baudrate=9600, retries=0) as bus:  # hears only its own echo
        with pytest.raises(NoAnswer):
            bus.motor(1).ping()
        assert bus.stats.echo_frames == 1


def test_missing_port_says_what_to_do() -> None:
    with pytest.raises(PortError, match=r"not found.*list_ports"):
        Bus.open("/dev/does-not-exist-nurimc")


def test_permission_and_busy_errors_name_the_fix() -> None:
    assert "dialout" in str(_port_error("/dev/ttyUSB0", OSError(errno.EACCES, "Permission denied")))
    assert "another program" in str(_port_error("/dev/ttyUSB0", OSError(errno.EBUSY, "busy")))


def test_ftdi_latency_timer_is_detected(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "ttyUSB7").mkdir()
    (tmp_path / "ttyUSB7" / "latency_timer").write_text("16\n")
    latency, warning = estimate_latency("/dev/ttyUSB7", sysfs=tmp_path)
    assert latency == pytest.approx(0.017)
    assert warning is not None and "echo 1" in warning
    (tmp_path / "ttyUSB7" / "latency_timer").write_text("1\n")
    assert estimate_latency("/dev/ttyUSB7", sysfs=tmp_path)[1] is None
