#!/usr/bin/env python3
"""Issue 21's crash figure: `kill -9` of `nurimc record` after 20 s, and how much reads back.

A real `nurimc record` process against the simulator (`sim://?ids=1,2`, 50 readings per
second, the default 1 s checkpoint) is killed with SIGKILL 20 s after it said "ready"; the file
is then opened as it is by the mcap reader (through its index) and by rosbags, and the span of
/joint_states stamps read back is recorded (goal: >= 18 s).

Usage: python benchmarks/record_crash.py [--seconds 20]   (writes benchmarks/results/record-crash.json)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from nurimc.ros2 import msgs

RESULTS = Path(__file__).parent / "results" / "record-crash.json"
NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def run(seconds: float, checkpoint: float) -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "crash.mcap"
        proc = subprocess.Popen(
            [
                *(NURIMC, "--port", "sim://?ids=1,2", "record", "--mcap", str(path), "--ids", "1,2"),
                *("--rate", "50", "--checkpoint", str(checkpoint)),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "NO_COLOR": "1"},
        )
        assert proc.stdout is not None
        line = proc.stdout.readline()
        if not line.startswith("ready:"):
            proc.kill()
            raise SystemExit(f"record did not start: {line}{proc.stderr.read() if proc.stderr else ''}")
        ready = time.time_ns()
        time.sleep(seconds)
        killed = time.time_ns()
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        size = path.stat().st_size
        with path.open("rb") as stream:
            stamps = [
                msgs.JointState.deserialize(m.data).header.stamp.to_ns()
                for _, _, m in make_reader(stream).iter_messages(topics=["/joint_states"])
            ]
        typestore = get_typestore(Stores.ROS2_HUMBLE)
        with AnyReader([path], default_typestore=typestore) as reader:
            rosbags_count = sum(1 for c, _, _ in reader.messages() if c.topic == "/joint_states")
    return {
        "killed_after_s": round((killed - ready) / 1e9, 2),
        "checkpoint_s": checkpoint,
        "file_bytes": size,
        "joint_states_read_back": len(stamps),
        "joint_states_read_by_rosbags": rosbags_count,
        "seconds_read_back": round((stamps[-1] - stamps[0]) / 1e9, 2) if stamps else 0.0,
        "seconds_lost_before_kill": round((killed - stamps[-1]) / 1e9, 2) if stamps else None,
    }


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--checkpoint", type=float, default=1.0)
    args = parser.parse_args()
    result = run(args.seconds, args.checkpoint)
    result["goal"] = f">= {args.seconds - 2:g} s of joint_states read back after kill -9 at {args.seconds:g} s"
    result["met"] = result["seconds_read_back"] >= args.seconds - 2
    result["machine"] = f"{platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}"
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
