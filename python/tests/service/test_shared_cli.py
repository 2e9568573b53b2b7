"""From outside: `nurimc serve` holds a simulated port; other nurimc commands attach to it
(docs/service.md). Subprocesses on the real clock (marked realtime by the conftest rule)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

RATE = "115200"
READY: dict[int, str] = {}  # pid -> the ready line it printed


def nurimc(*args: str) -> list[str]:
    return [sys.executable, "-c", "from nurimc.cli.app import main; main()", *args]


def started(cmd: list[str], env: dict[str, str], ready: str, timeout: float = 60.0) -> subprocess.Popen[str]:
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        line = proc.stdout.readline()
        if ready in line:
            READY[proc.pid] = line
            return proc
        if not line and proc.poll() is not None:
            raise AssertionError(f"{cmd[3:]} ended: {proc.stderr.read() if proc.stderr else ''}")
    proc.kill()
    raise AssertionError(f"no {ready!r} line from {cmd[3:]}")


def ended(proc: subprocess.Popen[str]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture
def held(tmp_path: Path) -> Iterator[tuple[str, dict[str, str], subprocess.Popen[str], Path]]:
    runtime = tempfile.TemporaryDirectory(dir="/tmp", prefix="nmc")  # a socket path must stay short
    env = {**os.environ, "XDG_RUNTIME_DIR": runtime.name, "LANG": "C.UTF-8", "LANGUAGE": "en"}
    env.pop("NURIMC_PORT", None)
    link = tmp_path / "tty"
    sim = started(nurimc("sim", "--link", str(link), "--ids", "1,2", "--baud", RATE), env, "ready:")
    holder = started(nurimc("--port", str(link), "--baud", RATE, "serve"), env, "ready: serving")
    try:
        yield str(link), env, holder, tmp_path
    finally:
        ended(holder)
        ended(sim)
        runtime.cleanup()


def run(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(nurimc(*args), capture_output=True, text=True, env=env, timeout=120)


def test_commands_attach_estop_stops_everything_and_the_end_of_the_holder_is_told(
    held: tuple[str, dict[str, str], subprocess.Popen[str], Path],
) -> None:
    port, env, holder, _ = held
    watch = subprocess.Popen(
        nurimc("--port", port, "--baud", RATE, "--id", "1,2", "watch", "--interval", "0.1"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        assert watch.stdout is not None
        watch.stdout.readline()  # its header: it reads through the holder
        status = run(env, "--port", port, "--baud", RATE, "--id", "2", "status", "--json")
        assert status.returncode == 0, status.stderr
        assert json.loads(status.stdout)
        listed = run(env, "--port", port, "clients", "--json")
        assert listed.returncode == 0, listed.stderr
        programs = sorted(c["program"] for c in json.loads(listed.stdout))
        assert programs == ["nurimc serve", "nurimc watch"]

        moved = run(env, "--port", port, "--baud", RATE, "--id", "1", "run", "30")
        assert moved.returncode == 0, moved.stderr
        stop = run(env, "--port", port, "estop", "--json")
        assert stop.returncode == 0, stop.stderr
        result = json.loads(stop.stdout)
        assert result["ok"] and result["stopped"] == [1, 2] and result["not_confirmed"] == []
        assert result["control"] == {"1": "off", "2": "off"}
        control = run(env, "--port", port, "--baud", RATE, "--id", "1", "get", "control", "--json")
        assert control.returncode == 0 and "off" in control.stdout  # and it stays off until commanded

        ended(holder)  # the holder ends: the attached watch says so in one line and exits 1
        assert watch.wait(30) == 1
        assert watch.stderr is not None
        said = watch.stderr.read()
        assert "no longer served" in said and "Traceback" not in said
    finally:
        ended(watch)


def test_a_second_holder_is_refused_and_nothing_attached_is_said(
    held: tuple[str, dict[str, str], subprocess.Popen[str], Path],
) -> None:
    port, env, _, _ = held
    second = run(env, "--port", port, "--baud", RATE, "serve")
    assert second.returncode != 0 and "already holds" in second.stderr and "Traceback" not in second.stderr
    nobody = run(env, "--port", port + "-other", "clients")
    assert nobody.returncode == 1 and "no nurimc program holds" in nobody.stderr


def test_the_console_attaches_shows_live_state_and_an_estop_from_elsewhere_reaches_its_page(
    held: tuple[str, dict[str, str], subprocess.Popen[str], Path],
) -> None:
    from ..dashboard.test_outside import ask, open_socket

    port, env, _, _ = held
    console = started(nurimc("--port", port, "--baud", RATE, "dashboard", "--listen", "127.0.0.1:0"), env, "ready:")
    try:
        listed = run(env, "--port", port, "clients", "--json")
        assert "nurimc dashboard" in {c["program"] for c in json.loads(listed.stdout)}
        address = re.search(r"ready: http://(\S+)/", READY[console.pid])
        assert address, READY[console.pid]
        with open_socket(address.group(1)) as ws:
            found = ask(ws, "discover", rates=[int(RATE)])
            assert found["ok"] and [m["id"] for m in found["result"]["motors"]] == [1, 2], found
            assert ask(ws, "watch", ids=[1, 2])["ok"]
            stopped = run(env, "--port", port, "estop", "--json")  # from another terminal
            assert stopped.returncode == 0, stopped.stderr
            rows: list[list[float]] = []
            estop_seen = None
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and (len(rows) < 20 or estop_seen is None):
                message = json.loads(ws.recv(timeout=30))
                if message.get("type") == "samples":
                    rows += message["rows"]
                elif message.get("type") == "estop":
                    estop_seen = message
            assert len(rows) >= 20 and {int(r[0]) for r in rows} == {1, 2}  # live state through the holder
            assert estop_seen is not None and estop_seen["stopped"] == [1, 2]  # the page is told of the stop
    finally:
        ended(console)
