"""Restore checks the line (issue 39, item 2): a backup of an RSA restored onto an MC is refused
before any write (no journal left to "run again"), values are checked against the controller's
line, and --force-line writes by name after a summary. Real CLI processes on a pseudo-terminal."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc.procedures.journal import RestoreJournal
from nurimc.sim import SimBus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def cli(port: str, state: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "NURIMC_STATE_DIR": str(state)}
    return subprocess.run([NURIMC, "--port", port, *args], capture_output=True, text=True, timeout=120, env=env)


@pytest.fixture
def buses() -> Iterator[tuple[SimBus, str, SimBus, str]]:
    """An RSA at ID 1 and, on another port, an MC at ID 1."""
    rsa, mc = SimBus(), SimBus()
    rsa.add_controller(id=1, baud=9600, product="rsa")
    mc.add_controller(id=1, baud=9600, product="mc")
    ends = rsa.serve_pty(), mc.serve_pty()
    yield rsa, ends[0].path, mc, ends[1].path
    for end in ends:
        end.stop()
    rsa.close()
    mc.close()


def test_a_backup_of_an_rsa_is_refused_on_an_mc_before_any_write(
    buses: tuple[SimBus, str, SimBus, str], tmp_path: Path
) -> None:
    _, rsa_port, mc, mc_port = buses
    state, backup = tmp_path / "state", tmp_path / "rsa.json"
    made = cli(rsa_port, state, "--id", "1", "backup", str(backup))
    assert made.returncode == 0, made.stderr
    assert json.loads(backup.read_text())["motors"][0]["product"] == "rsa"
    before = mc.controllers[0].settings.to_dict()
    refused = cli(mc_port, state, "restore", str(backup))
    assert refused.returncode == 2, refused.stderr
    lines = [line for line in refused.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "refused before any write" in lines[0] and "--force-line" in lines[0]
    assert "rsa" in lines[0] and "Traceback" not in refused.stderr
    assert mc.controllers[0].settings.to_dict() == before
    assert RestoreJournal(mc_port, state / "restore").pending(1) is None  # nothing to "run again"
    again = cli(mc_port, state, "restore", str(backup))  # and running it again changes nothing either
    assert again.returncode == 2 and mc.controllers[0].settings.to_dict() == before


def test_force_line_writes_by_name_after_a_summary(buses: tuple[SimBus, str, SimBus, str], tmp_path: Path) -> None:
    _, rsa_port, mc, mc_port = buses
    state, backup = tmp_path / "state", tmp_path / "rsa.json"
    assert cli(rsa_port, state, "--id", "1", "set", "position-kp", "77").returncode == 0
    assert cli(rsa_port, state, "--id", "1", "backup", str(backup)).returncode == 0
    rated = mc.controllers[0].settings.to_dict()["rated_speed"]
    forced = cli(mc_port, state, "restore", str(backup), "--force-line")
    assert forced.returncode == 0, forced.stderr
    assert "the controller is MC" in forced.stderr and "--force-line: writing its settings by name" in forced.stderr
    after = mc.controllers[0].settings.to_dict()
    assert after["position_kp"] == 77  # by name, in the MC's own command
    assert after["rated_speed"] == rated  # and nothing the RSA's bytes would have meant on an MC


def test_values_outside_the_target_line_are_refused_before_any_write(
    buses: tuple[SimBus, str, SimBus, str], tmp_path: Path
) -> None:
    from nurimc.drivers.sync import Bus
    from nurimc.procedures import config

    _, _, _mc, mc_port = buses
    with Bus.open(mc_port, 9600) as bus:
        motor = bus.motor(1, "mc")
        document = bus.run(config.backup([motor.procedures]))
        document["motors"][0]["product"] = "rsa"
        with pytest.raises(config.LineMismatch, match="refused before any write"):
            bus.run(config.restore([motor.procedures], document))
        document["motors"][0]["product"] = "blmc-h"  # the same line as an MC: no mismatch
        assert config.restore_check([motor.procedures], document) == []
