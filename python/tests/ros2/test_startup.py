"""Start-up: a first reading that no motor answers is retried with a clear line, never an exit."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from nurimc.errors import NurimcError
from nurimc.ros2.bridge import Bridge
from nurimc.ros2.dds import Participant
from nurimc.ros2.node import BridgeNode

from ..client.simfixtures import sim_bus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def test_a_failed_first_reading_is_retried_until_the_motor_answers() -> None:
    sim, bus = sim_bus([])  # nobody on the bus yet (a controller powered later, a busy host)
    lines: list[str] = []
    node = BridgeNode(bus, Bridge([1], ["a"]), Participant(), "/startup", log=lines.append, node_name=None)
    stop = threading.Event()
    result: list[object] = []
    worker = threading.Thread(target=lambda: result.append(node.prepare(0, stop=stop, retry=0.02)), daemon=True)
    try:
        worker.start()
        deadline = time.monotonic() + 10
        while not any("first reading failed (attempt 1)" in line for line in lines):
            assert time.monotonic() < deadline, lines
            time.sleep(0.01)
        assert worker.is_alive()  # retrying, not ended
        assert "retrying every 0.02 s until a motor answers (Ctrl-C to stop)" in lines[0]
        sim.add_controller(id=1, baud=9600)
        worker.join(10)
        assert not worker.is_alive() and result, lines
        assert node.bridge.joints[0].state is not None
        assert lines[-1].startswith("first reading succeeded on attempt ")
        # the same line is not repeated at every try (at most every 2 s)
        assert sum("first reading failed" in line for line in lines) <= 3, lines
    finally:
        stop.set()
        worker.join(10)
        node.close()
        bus.close()


def test_without_a_stop_event_the_first_failure_raises_at_once() -> None:
    _, bus = sim_bus([])
    node = BridgeNode(bus, Bridge([1], ["a"]), Participant(), "/startup2", log=lambda _: None, node_name=None)
    try:
        with pytest.raises(NurimcError):
            node.prepare(0)
    finally:
        node.close()
        bus.close()


def test_the_bridge_process_waits_for_a_motor_and_ctrl_c_ends_it_with_one_line() -> None:
    argv = [NURIMC, "--port", "sim://?ids=1", "--baud", "9600", "ros2", "--ids", "7", "--namespace", "/nobody"]
    process = subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "NO_COLOR": "1"}
    )
    assert process.stderr is not None
    try:
        line = process.stderr.readline()  # blocks until the bridge says something
        assert "first reading failed (attempt 1)" in line and "ID 7" in line, line
        assert process.poll() is None  # still there, retrying
    finally:
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=20)
    assert process.returncode != 0
    assert "ready:" not in out
    assert "Traceback" not in err
    assert "stopped before any motor answered" in err, err
