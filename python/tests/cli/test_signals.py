"""SIGTERM (what systemd, Docker and `kill` send) is the normal end of a command that runs until
stopped: exit 0, no traceback, no error line (never 143). A one-shot command interrupted by it
says so in one line and exits 143."""

from __future__ import annotations

import os
import re
import selectors
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nurimc.dashboard.server import STATIC, UPLOT

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
SIM = "sim://?ids=0,1"


def start(*args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "NO_COLOR": "1", "COLUMNS": "200"}
    env.pop("NURIMC_PORT", None)
    return subprocess.Popen(
        [NURIMC, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, stdin=subprocess.DEVNULL
    )


def wait_for(proc: subprocess.Popen[str], pattern: str, timeout: float = 20) -> str:
    """Read stdout until a line matches (the command is up and working)."""
    assert proc.stdout is not None
    selector = selectors.DefaultSelector()
    selector.register(proc.stdout, selectors.EVENT_READ)
    seen = ""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if selector.select(timeout=0.2):
            line = proc.stdout.readline()
            if not line:
                break
            seen += line
            if re.search(pattern, line):
                return line
    proc.kill()
    pytest.fail(f"no line matching {pattern!r} within {timeout} s; stdout {seen!r}; stderr {proc.communicate()[1]!r}")


def terminate(proc: subprocess.Popen[str]) -> tuple[int, str, str]:
    proc.send_signal(signal.SIGTERM)
    try:
        out, err = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("still running 15 s after SIGTERM")
    return proc.returncode, out, err


@pytest.mark.parametrize(
    ("args", "running"),
    [
        (["--port", SIM, "sniff"], None),  # prints nothing until a frame passes: wait a moment
        (["--port", SIM, "--id", "1", "watch", "--interval", "0.05"], None),  # off a terminal: lines
        (["--port", SIM, "--id", "0,1", "--json", "watch", "--interval", "0.05"], None),
    ],
    ids=["sniff", "watch", "watch --json"],
)
def test_long_runners_end_cleanly_on_sigterm(args: list[str], running: str | None) -> None:
    proc = start(*args)
    if running:
        wait_for(proc, running)
    else:
        time.sleep(1.5)  # started, opened the simulated bus, listening
        assert proc.poll() is None, proc.communicate()
    code, out, err = terminate(proc)
    assert code == 0, (code, err)
    assert "Traceback" not in err and "error:" not in err, err
    if "--json" in args:
        assert out.lstrip().startswith("[") and '"position_deg"' in out  # the readings so far, as promised
    elif "watch" in args:
        lines = out.splitlines()  # to a pipe: a header, then a line per motor and reading
        assert "position sign" in lines[0] and len(lines) >= 2 and all(x.startswith("1\t") for x in lines[1:])


@pytest.mark.skipif(not (STATIC / UPLOT).is_file(), reason="the console's assets: bash scripts/dashboard-assets.sh")
def test_dashboard_ends_cleanly_on_sigterm() -> None:
    proc = start("dashboard", "--sim", "--listen", "127.0.0.1:0")
    wait_for(proc, r"ready: http://127\.0\.0\.1:\d+/")
    code, _, err = terminate(proc)
    assert code == 0, (code, err)
    assert "Traceback" not in err and "error:" not in err, err


def test_a_one_shot_command_says_it_was_terminated() -> None:
    # demo runs for several seconds: SIGTERM in the middle is an interruption, not its normal end
    proc = start("demo", "--seconds", "30")
    wait_for(proc, r"nurimc demo")
    code, _, err = terminate(proc)
    assert code == 143, (code, err)
    assert err.strip().splitlines()[-1] == "error: terminated (SIGTERM) before the command finished", err
    assert "Traceback" not in err
