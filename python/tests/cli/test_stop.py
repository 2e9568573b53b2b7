"""Stopping and waiting from outside: `run 0` and `stop` bring a turning motor to rest under both
readings of speed 0 (the simulator's `--speed-zero stop` and `ignore`), and `move --wait`
returns at the target or says in one line that it did not get there."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc.sim import SimBus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def cli(port: str, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    env.pop("NURIMC_PORT", None)
    return subprocess.run(
        [NURIMC, "--port", port, "--id", "1", *args], capture_output=True, text=True, timeout=60, env=env
    )


def reading(port: str) -> dict[str, float]:
    proc = cli(port, "--json", "status")
    assert proc.returncode == 0, proc.stderr
    state: dict[str, float] = json.loads(proc.stdout)["state"]
    return state


@pytest.fixture(params=["stop", "ignore"])
def port(request: pytest.FixtureRequest) -> Iterator[str]:
    sim = SimBus(eeprom_time=0.02, speed_zero=request.param)
    controller = sim.add_controller(id=1, baud=9600)
    controller.settings.resolution = 1024  # encoder-like steps, as `nurimc sim` has by default
    controller.apply_settings()
    endpoint = sim.serve_pty()
    yield endpoint.path
    endpoint.stop()
    sim.close()


@pytest.mark.parametrize("how", [("run", "0"), ("stop",)])
def test_a_turning_motor_comes_to_rest_and_holds(port: str, how: tuple[str, ...]) -> None:
    assert cli(port, "run", "120", "--ramp", "0.2").returncode == 0
    deadline = time.monotonic() + 30
    while reading(port)["speed_rpm"] < 100:
        assert time.monotonic() < deadline, "the motor never reached 120 RPM"
    stopped = cli(port, "--json", *how)
    assert stopped.returncode == 0, stopped.stderr
    assert json.loads(stopped.stdout)["stopped"] is True
    first = reading(port)
    time.sleep(0.5)
    later = reading(port)
    assert later["speed_rpm"] < 1 and abs(later["device_position_deg"] - first["device_position_deg"]) < 1
    control = cli(port, "--json", "get", "control")
    assert json.loads(control.stdout)["value"] == "on"  # held, not released


def test_move_wait_returns_at_the_target(port: str) -> None:
    moved = cli(port, "--json", "move", "90", "--rpm", "120", "--wait")
    assert moved.returncode == 0, moved.stderr
    assert abs(json.loads(moved.stdout)["arrived_deg"] - 90) <= 1
    assert abs(reading(port)["device_position_deg"] - 90) <= 1


def test_move_wait_that_times_out_is_one_line(port: str) -> None:
    late = cli(port, "move", "-300", "--rpm", "5", "--wait", "--timeout", "0.3")
    assert late.returncode == 1, late.stderr
    assert late.stderr.startswith("error: ID 1: not at -300° after 0.3 s"), late.stderr
    assert late.stderr.count("\n") == 1, late.stderr
    stopped = cli(port, "stop")
    assert stopped.returncode == 0, stopped.stderr
