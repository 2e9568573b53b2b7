"""The other ways in: TCP (socket://), the sim:// URL, and the CLI as a subprocess."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import serial

import nurimc.sim  # noqa: F401 - registers the sim:// handler
from nurimc.sim import SimBus

from .wirehelp import ask, command, frame, silent, u16


def test_tcp_with_socket_url() -> None:
    bus = SimBus(eeprom_time=0.01)
    bus.add_controller(0)
    bus.add_controller(4)
    server = bus.serve_tcp(port=0)
    try:
        assert server.address[0] == "127.0.0.1"
        port = serial.serial_for_url(f"socket://{server.address[0]}:{server.address[1]}", timeout=0.3)
        try:
            assert ask(port, 4, 0xA0) == b""
            command(port, 0, "set_rated_speed", u16(2500))
            assert ask(port, 0, 0xA6) == u16(2500)
        finally:
            port.close()
    finally:
        server.stop()
        bus.close()


def test_sim_url() -> None:
    port = serial.serial_for_url("sim://?ids=0,1,2&baud=9600&product=blmc-h&wire_timing=0&motor=3@57600", timeout=0.3)
    try:
        assert [c.id for c in port.bus.controllers] == [0, 1, 2, 3]
        assert ask(port, 2, 0xA3) == bytes([40, 0, 15, 80])
        assert silent(port, 3, 0xA0)
        port.baudrate = 57600  # the bus model sees the new rate
        assert ask(port, 3, 0xA0) == b""
    finally:
        port.close()


def test_sim_url_errors_are_clear() -> None:
    with pytest.raises(serial.SerialException, match="unknown parameter"):
        serial.serial_for_url("sim://?idz=3")
    with pytest.raises(serial.SerialException, match="not a rate"):
        serial.serial_for_url("sim://?baud=1234")


def _start(args: list[str]) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "nurimc.sim", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stdout is not None
    lines = []
    for line in proc.stdout:
        lines.append(line)
        if line.startswith("ready: "):
            return proc, line.removeprefix("ready: ").strip()
    proc.wait(timeout=60)
    raise AssertionError(f"no ready line: {lines} {proc.stderr.read() if proc.stderr else ''}")


def test_cli_serves_pty_until_sigterm(tmp_path: Path) -> None:
    link = tmp_path / "ttySIM"
    proc, where = _start(["--link", str(link), "--ids", "0,1", "--baud", "115200", "--motor", "9@57600", "-v"])
    try:
        assert where == str(link) and link.is_symlink()
        with serial.Serial(str(link), 115200, timeout=0.5) as port:
            assert ask(port, 1, 0xA0) == b""
            port.baudrate = 57600
            assert ask(port, 9, 0xA0) == b""
    finally:
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "stopped" in out
    assert "request_ping" in err.lower() or "RequestPing" in err  # -v logged the frames
    assert not link.exists()


def test_cli_tcp_and_bad_options() -> None:
    proc, where = _start(["--tcp", "0", "--ids", "0-1"])
    try:
        host, _ = where.split(":")
        assert host == "127.0.0.1"
        with serial.serial_for_url(f"socket://{where}", timeout=0.5) as port:
            port.write(frame(1, 0xA0))
            assert port.read(6) == frame(1, 0xD0)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
    assert proc.returncode == 0
    bad = subprocess.run(
        [sys.executable, "-m", "nurimc.sim", "--motor", "3-57600"], capture_output=True, text=True, timeout=30
    )
    assert bad.returncode == 2 and "ID@RATE" in bad.stderr
