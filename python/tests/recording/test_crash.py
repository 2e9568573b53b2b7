"""Recordings survive a crash: a real `nurimc record` process killed with SIGKILL leaves a file
that the mcap reader and rosbags open as it is, holding everything up to the last checkpoint;
a port that dies ends the recording properly with a non-zero exit.

Real-time end-to-end tests (a process, a real kill): the bounds are generous."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from nurimc.recording.mcap_file import FRAMES_TOPIC
from nurimc.ros2 import msgs

from ..ros2.rosbags_types import plain, typestore
from .test_mcap import NURIMC, make_recording

ENV = {**os.environ, "NO_COLOR": "1", "COLUMNS": "200"}


def wait_for_line(proc: subprocess.Popen[str], start: str, timeout: float = 30) -> str:
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if line.startswith(start):
            return line
        if not line and proc.poll() is not None:
            break
    raise AssertionError(f"no line starting {start!r}; stderr: {proc.stderr.read() if proc.stderr else ''}")


def joint_state_stamps(path: Path) -> list[int]:
    """Stamps of /joint_states as the mcap reader (through the file's index) gives them."""
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes  # an indexed file, not a torn one
        return [
            msgs.JointState.deserialize(m.data).header.stamp.to_ns()
            for _, _, m in reader.iter_messages(topics=["/joint_states"])
        ]


def test_kill_9_keeps_everything_up_to_the_last_checkpoint(tmp_path: Path) -> None:
    path = tmp_path / "crash.mcap"
    proc = subprocess.Popen(
        [NURIMC, "--port", "sim://?ids=1,2", "record", "--mcap", str(path), "--ids", "1,2", "--rate", "20"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    try:
        wait_for_line(proc, "ready:", timeout=90)
        wait_for_recorded(path, 2.5)  # checkpointed on disk: what the kill must not lose
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == -signal.SIGKILL
    stamps = joint_state_stamps(path)
    assert (stamps[-1] - stamps[0]) / 1e9 >= 2.0, f"only {(stamps[-1] - stamps[0]) / 1e9:.2f} s read back"
    with AnyReader([path], default_typestore=typestore()) as reader:
        topics = {c.topic for c in reader.connections}
        assert topics == {"/joint_states", FRAMES_TOPIC}
        theirs: list[Any] = [reader.deserialize(data, c.msgtype) for c, _, data in reader.messages()]
    assert [
        m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in theirs if hasattr(m, "header")
    ] == stamps


def wait_for_recorded(path: Path, seconds: float, timeout: float = 90) -> None:
    """Wait until the file, read as it is on disk (its last checkpoint), holds `seconds` of
    /joint_states (0: at least one), instead of sleeping and hoping the busy machine kept up."""
    deadline = time.monotonic() + timeout
    span = -1.0
    while time.monotonic() < deadline:
        try:
            stamps = joint_state_stamps(path)
        except Exception:  # not written yet, or between checkpoints: try again
            stamps = []
        if stamps:
            span = (stamps[-1] - stamps[0]) / 1e9
            if span >= seconds:
                return
        time.sleep(0.1)
    raise AssertionError(f"{path}: {span:.2f} s of /joint_states after {timeout} s (wanted {seconds} s)")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


def test_record_exits_non_zero_when_its_port_dies(tmp_path: Path) -> None:
    port = free_port()
    sim = subprocess.Popen(
        [sys.executable, "-m", "nurimc.sim", "--ids", "1", "--tcp", str(port)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=ENV,
    )
    path = tmp_path / "lost.mcap"
    record = None
    try:
        wait_for_line(sim, "ready:", timeout=90)
        record = subprocess.Popen(
            [
                NURIMC,
                "--port",
                f"socket://127.0.0.1:{port}",
                "record",
                "--mcap",
                str(path),
                "--ids",
                "1",
                "--port-wait",
                "1",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=ENV,
        )
        wait_for_line(record, "ready:", timeout=90)
        wait_for_recorded(path, 0)  # something recorded before the loss
        sim.terminate()
        sim.wait(timeout=60)
        stdout, stderr = record.communicate(timeout=90)
    finally:
        for p in (sim, record):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
    assert record.returncode == 1, stderr
    assert "the recording stopped early" in stderr and "Traceback" not in stderr
    assert f"wrote {path}" in stdout
    assert joint_state_stamps(path)  # closed properly: indexed, with what came before the loss


def test_repair_mcap_keeps_every_whole_record_of_a_torn_file(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    written, _ = make_recording(whole)
    torn = tmp_path / "torn.mcap"
    data = whole.read_bytes()
    torn.write_bytes(data[: len(data) - 200])  # the footer, the summary and part of the index gone
    proc = subprocess.run(
        [NURIMC, "repair-mcap", str(torn), "--out", str(tmp_path / "fixed.mcap")],
        capture_output=True,
        text=True,
        timeout=30,
        env=ENV,
    )
    assert proc.returncode == 0, proc.stderr
    assert "messages kept" in proc.stdout
    with AnyReader([tmp_path / "fixed.mcap"], default_typestore=typestore()) as reader:
        states = [
            plain(reader.deserialize(d, c.msgtype)) for c, _, d in reader.messages() if c.topic == "/joint_states"
        ]
    assert states == [plain(m) for m in written]
    not_mcap = subprocess.run([NURIMC, "repair-mcap", str(tmp_path)], capture_output=True, text=True, env=ENV)
    assert not_mcap.returncode == 2 and "Traceback" not in not_mcap.stderr
