"""Restore is a transaction from the user's view: a `nurimc restore` killed mid-way (SIGKILL,
a real process on a pseudo-terminal to the simulator) is found by the next `status` and
`restore`, and running restore again completes it."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc.procedures.journal import RestoreJournal
from nurimc.sim import SimBus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
CHANGED = {"position-kp": "99", "speed-kp": "77", "response-time": "500us", "rated-speed": "2000", "ratio": "5"}


@pytest.fixture
def slow_eeprom() -> Iterator[tuple[SimBus, str]]:
    sim = SimBus(eeprom_time=0.25)  # each write keeps the controller busy: the restore takes seconds
    sim.add_controller(id=1, baud=9600)
    endpoint = sim.serve_pty()
    yield sim, endpoint.path
    endpoint.stop()
    sim.close()


def cli(port: str, state: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "NURIMC_STATE_DIR": str(state)}
    return subprocess.run([NURIMC, "--port", port, *args], capture_output=True, text=True, timeout=120, env=env)


def test_an_interrupted_restore_is_found_and_completed(slow_eeprom: tuple[SimBus, str], tmp_path: Path) -> None:
    sim, port = slow_eeprom
    state, backup = tmp_path / "state", tmp_path / "robot.json"
    assert cli(port, state, "--id", "1", "backup", str(backup)).returncode == 0
    saved = sim.controllers[0].settings.to_dict()
    for name, value in CHANGED.items():
        assert cli(port, state, "--id", "1", "set", name, value).returncode == 0
    changed = sim.controllers[0].settings.to_dict()

    env = {**os.environ, "NO_COLOR": "1", "NURIMC_STATE_DIR": str(state)}
    proc = subprocess.Popen([NURIMC, "--port", port, "restore", str(backup)], env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while sim.controllers[0].settings.to_dict() == changed:  # kill it once the first write has landed
            assert time.monotonic() < deadline and proc.poll() is None, "restore wrote nothing"
            time.sleep(0.01)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    mixed = sim.controllers[0].settings.to_dict()
    assert mixed not in (saved, changed)  # part old, part restored: the case to catch

    message = f"incomplete restore of {backup.resolve()}: run restore again"
    status = cli(port, state, "--id", "1", "--json", "status")
    assert status.returncode == 0 and message in status.stderr
    assert json.loads(status.stdout)["incomplete_restore"] == str(backup.resolve())

    again = cli(port, state, "restore", str(backup))
    assert again.returncode == 0, again.stderr
    assert message in again.stderr
    assert sim.controllers[0].settings.to_dict() == saved
    assert RestoreJournal(port, state / "restore").pending(1) is None
    after = cli(port, state, "--id", "1", "status")
    assert after.returncode == 0 and "incomplete restore" not in after.stderr
