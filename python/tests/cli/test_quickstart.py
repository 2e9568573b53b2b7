"""The README's quick start, pasted as written: the simulator started with --background is
ready when the command returns, so the scan right after it finds both controllers (issue 38:
`nurimc sim ... &` then `scan` found no port 2 runs in 3). Also --port-wait, for a port that
appears a moment after the command starts."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
BIN = Path(sys.executable).parent
NURIMC = shutil.which("nurimc", path=str(BIN)) or "nurimc"
ENV = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", "NO_COLOR": "1", "COLUMNS": "200"}
ENV.pop("NURIMC_PORT", None)


def quick_start() -> list[str]:
    """The commands of the README's quick start (comments dropped), without `make venv`."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("## Quick start", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    commands = [line.split("  #", 1)[0].strip() for line in block.strip().splitlines()]
    return [c for c in commands if c and not c.startswith("make ")]


def stop(pid: int) -> None:
    os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)


def test_the_readme_runs_the_simulator_in_the_background() -> None:
    sim, scan = quick_start()[:2]
    assert sim.startswith("nurimc sim ") and sim.endswith("--background"), sim
    assert "scan" in scan


@pytest.mark.parametrize("attempt", range(3))
def test_quick_start_pasted_finds_both_controllers(tmp_path: Path, attempt: int) -> None:
    link = str(tmp_path / "nurimc0")
    sim, scan = (c.replace("/tmp/nurimc0", link) for c in quick_start()[:2])
    started = subprocess.run(sim, shell=True, capture_output=True, text=True, env=ENV, timeout=180)
    pid_match = re.search(r"kill (\d+)", started.stdout)
    try:
        assert started.returncode == 0, started.stderr
        assert f"ready: {link}" in started.stdout and pid_match, started.stdout
        found = subprocess.run(scan, shell=True, capture_output=True, text=True, env=ENV, timeout=180)
        assert found.returncode == 0, found.stderr
        assert "2 controller(s) found" in found.stdout, found.stdout
    finally:
        if pid_match:
            stop(int(pid_match.group(1)))


def test_background_start_that_fails_returns_its_error() -> None:
    done = subprocess.run(
        [NURIMC, "sim", "--ids", "1", "--product", "nope", "--background"],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=180,
    )
    assert done.returncode == 2 and "--product 'nope'" in done.stderr, (done.returncode, done.stderr)
    assert "background" not in done.stdout


def test_port_wait_waits_for_a_port_that_appears(tmp_path: Path) -> None:
    link = tmp_path / "late"
    scan = subprocess.Popen(
        [NURIMC, "--port-wait", "120", "--port", str(link), "scan", "--rates", "9600"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    sim = subprocess.Popen(
        [NURIMC, "sim", "--link", str(link), "--ids", "1,2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    try:
        out, err = scan.communicate(timeout=180)
        assert scan.returncode == 0, err
        assert "2 controller(s) found" in out, out
    finally:
        for p in (scan, sim):
            if p.poll() is None:
                p.terminate()
                p.communicate(timeout=60)


def test_port_wait_gives_up_saying_it_waited(tmp_path: Path) -> None:
    done = subprocess.run(
        [NURIMC, "--port-wait", "0.3", "--port", str(tmp_path / "never"), "scan"],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
    )
    assert done.returncode != 0 and "Traceback" not in done.stderr
    assert "not found" in done.stderr and "(waited 0.3 s, --port-wait)" in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


def test_global_option_after_the_command_says_where_it_goes() -> None:
    done = subprocess.run([NURIMC, "status", "--id", "1"], capture_output=True, text=True, env=ENV, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip() == "error: --id is a global option: nurimc --id 1 status", done.stderr
