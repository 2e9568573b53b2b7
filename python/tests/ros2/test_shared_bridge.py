"""Issue 32's "done when", from outside: `nurimc ros2` holds a simulated port and moves a motor
on a DDS command; `status`, `clients` and `estop` from other processes attach to it; the stop
reads every motor back off and the bridge reports it; ending the bridge is told to an attached
`watch` (docs/service.md). Subprocesses, loopback DDS only (conftest)."""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from .peer import JointState, Peer, command
from .test_end_to_end import near, unique

BAUD = "115200"


def nurimc(*args: str) -> list[str]:
    return [sys.executable, "-c", "from nurimc.cli.app import main; main()", *args]


class Process:
    def __init__(self, argv: list[str], env: dict[str, str], ready: str | None) -> None:
        self.process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.out: queue.Queue[str] = queue.Queue()
        self.err: list[str] = []
        assert self.process.stdout is not None and self.process.stderr is not None
        threading.Thread(target=self._pump, args=(self.process.stdout, self.out.put), daemon=True).start()
        threading.Thread(target=self._pump, args=(self.process.stderr, self.err.append), daemon=True).start()
        end = time.monotonic() + 60
        while ready is not None:
            try:
                line = self.out.get(timeout=max(0.1, end - time.monotonic()))
            except queue.Empty:
                self.stop()
                raise AssertionError(f"{argv[3:]} did not start: {''.join(self.err)}") from None
            if ready in line:
                break

    @staticmethod
    def _pump(stream: object, put: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            put(line)  # type: ignore[operator]

    def said(self, text: str, timeout: float = 20) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if any(text in line for line in self.err):
                return True
            time.sleep(0.05)
        return False

    def stop(self) -> int | None:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            return self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return None


@pytest.fixture
def bus_env() -> Iterator[tuple[str, dict[str, str]]]:
    runtime = tempfile.TemporaryDirectory(dir="/tmp", prefix="nmc")  # a socket's path must stay short
    env = {**os.environ, "XDG_RUNTIME_DIR": runtime.name, "NO_COLOR": "1", "LANGUAGE": "en", "LANG": "C.UTF-8"}
    env.pop("NURIMC_PORT", None)
    link = str(Path(runtime.name) / "tty")
    sim = Process(nurimc("sim", "--link", link, "--ids", "1,2", "--baud", BAUD), env, "ready:")
    try:
        yield link, env
    finally:
        sim.stop()
        runtime.cleanup()


def run(env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(nurimc(*args), capture_output=True, text=True, env=env, timeout=120)


def test_the_bridge_holds_the_port_and_everything_else_attaches(bus_env: tuple[str, dict[str, str]]) -> None:
    port, env = bus_env
    ns = unique("shared")
    peer = Peer()
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    velocities = peer.publisher(f"{ns}/velocity_commands", type(command([])))
    bridge = Process(nurimc("--port", port, "--baud", BAUD, "ros2", "--ids", "1,2", "--namespace", ns), env, "ready:")
    watch = None
    try:
        states.wait_for(lambda s: True, 15, "joint_states")
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:  # a ROS controller turning joint 1 at 2 rad/s
            velocities.write(command([2.0, 0.0]))
            if states.poll() and near(states.poll()[-1].velocity[0], 2.0, 0.1):
                break
            time.sleep(0.05)
        assert near(states.poll()[-1].velocity[0], 2.0, 0.1), "the bridge did not move the motor"

        status = run(env, "--port", port, "--baud", BAUD, "--id", "2", "status", "--json")
        assert status.returncode == 0, status.stderr
        watch = Process(nurimc("--port", port, "--baud", BAUD, "--id", "1,2", "watch", "--interval", "0.1"), env, "ID")
        listed = run(env, "--port", port, "clients", "--json")
        assert listed.returncode == 0, listed.stderr
        assert {"nurimc ros2", "nurimc watch"} <= {c["program"] for c in json.loads(listed.stdout)}

        stop = run(env, "--port", port, "estop", "--json")
        assert stop.returncode == 0, stop.stderr
        result = json.loads(stop.stdout)
        assert result["ok"] and result["stopped"] == [1, 2] and result["control"] == {"1": "off", "2": "off"}
        assert bridge.said("estop on the shared bus: control off read back on ID 1, 2")
        states.wait_for(lambda s: s.velocity[0] == 0.0, 10, "joint 1 stopped")
        control = run(env, "--port", port, "--baud", BAUD, "--id", "1", "get", "control", "--json")
        assert control.returncode == 0 and "off" in control.stdout  # stopped until commanded again

        assert bridge.stop() == 0  # the holder ends: the attached watch is told, in one line, exit 1
        assert watch.process.wait(30) == 1
        assert watch.said("is no longer served") and not any("Traceback" in line for line in watch.err)
    finally:
        if watch is not None:
            watch.stop()
        bridge.stop()
        peer.close()
