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


def wait_for(
    proc: subprocess.Popen[str], pattern: str, timeout: float = 60, *, stderr: bool = False, times: int = 1
) -> str:
    """Read stdout (or stderr) until `times` lines match (the command is up and working); return
    everything read."""
    stream = proc.stderr if stderr else proc.stdout
    assert stream is not None
    selector = selectors.DefaultSelector()
    selector.register(stream, selectors.EVENT_READ)
    seen = ""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if selector.select(timeout=0.2):
            line = stream.readline()
            if not line:
                break
            seen += line
            if re.search(pattern, line):
                times -= 1
                if times <= 0:
                    return seen
    proc.kill()
    pytest.fail(f"no line matching {pattern!r} within {timeout} s; {'stderr' if stderr else 'stdout'} {seen!r}")


def wait_until_listening(proc: subprocess.Popen[str], timeout: float = 60) -> None:
    """Wait until the command catches SIGTERM (its handler is installed, so the command is known)
    and the in-process simulator's thread runs (the bus is open): the condition a fixed sleep
    used to guess at. Linux: read from /proc/PID/status."""
    status = Path(f"/proc/{proc.pid}/status")
    deadline = time.monotonic() + timeout
    fields: dict[str, str] = {}
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        try:
            fields = dict(line.split(":\t", 1) for line in status.read_text().splitlines() if ":\t" in line)
        except OSError:
            fields = {}
        catches_term = int(fields.get("SigCgt", "0").strip(), 16) & (1 << (signal.SIGTERM - 1))
        if catches_term and int(fields.get("Threads", "1").strip()) >= 2:
            return
        time.sleep(0.02)
    proc.kill()
    pytest.fail(f"not listening within {timeout} s: {fields.get('Threads')=} {fields.get('SigCgt')=}")


def terminate(proc: subprocess.Popen[str]) -> tuple[int, str, str]:
    proc.send_signal(signal.SIGTERM)
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("still running 60 s after SIGTERM")
    return proc.returncode, out, err


@pytest.mark.parametrize(
    "args",
    [
        ["--port", SIM, "sniff"],  # prints nothing until a frame passes: wait until it listens
        ["--port", SIM, "--id", "1", "watch", "--interval", "0.05"],  # off a terminal: lines
        # -v: the frames on stderr show the first reading done and the second one asked for
        ["--port", SIM, "--id", "0,1", "--json", "-v", "watch", "--interval", "0.05"],
    ],
    ids=["sniff", "watch", "watch --json"],
)
def test_long_runners_end_cleanly_on_sigterm(args: list[str]) -> None:
    proc = start(*args)
    before = ""  # stdout read while waiting
    if "sniff" in args:
        wait_until_listening(proc)  # started, opened the simulated bus, listening
    elif "--json" in args:
        wait_for(proc, r"^<- position_feedback id=1 ", stderr=True, times=2)
    else:
        before = wait_for(proc, r"^1\t")  # a reading printed: watching
    code, out, err = terminate(proc)
    out = before + out
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
