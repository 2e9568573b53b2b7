"""`nurimc ros2` across a port outage: a real bridge process on a port the test cuts and restores."""

from __future__ import annotations

import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc.protocol import SetControl

from ..transport.outage import BAUD, cuttable_bus, frames_after_cut
from .peer import JointState, Peer, command

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


class Bridge:
    def __init__(self, port: str, namespace: str, *options: str) -> None:
        argv = [NURIMC, "--port", port, "--baud", str(BAUD), "ros2", "--ids", "1", "--namespace", namespace, *options]
        env = {**os.environ, "NO_COLOR": "1"}
        self.process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        self.lines: queue.Queue[str] = queue.Queue()
        self.stderr: list[str] = []
        assert self.process.stdout is not None and self.process.stderr is not None
        threading.Thread(target=self._pump, args=(self.process.stdout, self.lines.put), daemon=True).start()
        threading.Thread(target=self._pump, args=(self.process.stderr, self.stderr.append), daemon=True).start()
        line = self.lines.get(timeout=90)
        assert line.startswith("ready:"), line + "".join(self.stderr)

    @staticmethod
    def _pump(stream: object, put: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            put(line)  # type: ignore[operator]

    def said(self, text: str) -> int:
        return sum(text in line for line in self.stderr)

    def wait_said(self, text: str, timeout: float) -> None:
        deadline = time.monotonic() + timeout
        while not self.said(text):
            assert time.monotonic() < deadline, f"the bridge never said {text!r}: {''.join(self.stderr)}"
            time.sleep(0.02)

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            return self.process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.process.kill()
            raise


@pytest.fixture
def peer() -> Iterator[Peer]:
    p = Peer()
    yield p
    p.close()


def unique(name: str) -> str:
    return f"/{name}_{os.getpid()}_{time.monotonic_ns() % 10**6}"


def test_a_motor_whose_commands_timed_out_during_an_outage_is_stopped_first_on_return(
    peer: Peer, tmp_path: Path
) -> None:
    ns = unique("outage")
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    velocities = peer.publisher(f"{ns}/velocity_commands", command([]).__class__)
    with cuttable_bus("pty", tmp_path) as (sim, proxy):
        bridge = Bridge(proxy.url, ns, "--command-timeout", "0.3")
        try:
            states.wait_for(lambda s: True, 10, "joint_states")
            time.sleep(0.2)  # let discovery match our writer
            velocities.write(command([2.0]))
            states.wait_for(lambda s: abs(s.velocity[0] - 2.0) < 0.1, 3, "turning at 2 rad/s")
            proxy.cut()  # and the commands stop: the timeout's hold cannot go out
            bridge.wait_said("lost", 3)
            bridge.wait_said("control off is sent first when it returns", 3)
            assert sim.controllers[0].settings.control == 0  # still driven: nothing could reach it
            proxy.restore()
            bridge.wait_said("back after", 5)
            states.wait_for(lambda s: s.velocity[0] == 0.0, 3, "fresh joint_states, stopped")
            sent = frames_after_cut(proxy)
            assert sent[0] == SetControl(1, 1), sent[:3]  # the stop is the first frame after the return
            assert sent[1].name == "request_position", sent[:3]  # then the state is read, before anything else
            said = "".join(bridge.stderr)
            assert bridge.said(" lost (") == 1 and bridge.said("back after") == 1, said  # one line each
        finally:
            assert bridge.stop() == 0, "".join(bridge.stderr)


def test_ending_while_the_port_is_down_says_the_motors_could_not_be_stopped(peer: Peer, tmp_path: Path) -> None:
    ns = unique("down")
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    velocities = peer.publisher(f"{ns}/velocity_commands", command([]).__class__)
    with cuttable_bus("tcp", tmp_path) as (_, proxy):
        bridge = Bridge(proxy.url, ns, "--command-timeout", "0")
        try:
            states.wait_for(lambda s: True, 10, "joint_states")
            time.sleep(0.2)
            velocities.write(command([2.0]))
            states.wait_for(lambda s: abs(s.velocity[0] - 2.0) < 0.1, 3, "turning at 2 rad/s")
            proxy.cut()
            bridge.wait_said("lost", 3)
        finally:
            code = bridge.stop()
        text = "".join(bridge.stderr)
        assert "could not stop ID 1" in text and "may still be turning" in text, text
        assert code != 0
        assert "Traceback" not in text
