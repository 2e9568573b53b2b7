#!/usr/bin/env python3
"""Benchmark of the shared bus (docs/service.md), each program as a user would run it.

`nurimc sim --wire-timing` on a pseudo-terminal (2 motors, 115200 bps), `nurimc ros2 --rate 50`
holding it, an independent DDS subscriber counting joint_states (the tests' peer, loopback only):

1. joint_states rate with the bridge alone, then with the console (`nurimc dashboard`), a
   `watch` (10 readings/s of both motors) and a `record` attached: the ratio (goal >= 0.9).
2. Emergency-stop latency from an attached program: both motors turning, `estop` asked through
   the holder's socket until its answer (every motor read back off), repeated.
3. CPU of the holder (utime + stime from /proc) alone and with the three clients attached.

Usage: python benchmarks/service_bench.py [--seconds S]   (writes benchmarks/results/service.json)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "service.json"
sys.path.insert(0, str(HERE.parent / "python" / "tests"))
os.environ["CYCLONEDDS_URI"] = (  # loopback only, as the tests
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery></Domain></CycloneDDS>"
)
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(100, 200)))
RUNTIME = tempfile.TemporaryDirectory(dir="/tmp", prefix="nmcb")  # the sockets (a short path)
os.environ["XDG_RUNTIME_DIR"] = RUNTIME.name

from nurimc.service.share import AttachedBus, connect  # noqa: E402
from ros2.peer import JointState, Peer  # noqa: E402 - the tests' independent participant

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
BAUD = 115200
IDS = "1,2"


def ready_line(process: subprocess.Popen[str], timeout: float = 60) -> str:
    assert process.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if line.startswith("ready:"):
            return line.strip()
        if not line and process.poll() is not None:
            break
    raise RuntimeError(f"{process.args} did not start")


@contextmanager
def started(argv: list[str], ready: bool = True) -> Iterator[subprocess.Popen[str]]:
    out = subprocess.PIPE if ready else subprocess.DEVNULL
    process = subprocess.Popen(
        argv, stdout=out, stderr=subprocess.DEVNULL, text=True, env={**os.environ, "NO_COLOR": "1"}
    )
    try:
        if ready:
            ready_line(process)
        yield process
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def count_states(states: object, seconds: float) -> tuple[float, float]:
    """joint_states per second over `seconds` (polling often: the reader keeps the last 10)."""
    poll = states.poll  # type: ignore[attr-defined]
    before = len(poll())
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        poll()
        time.sleep(0.005)
    return (len(poll()) - before) / (time.monotonic() - start), time.monotonic() - start


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    peer = Peer()
    ns = "/svcbench"
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    result: dict[str, object] = {
        "host": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
        "note": "host busy: 2 cores shared with 8 other agents' builds and tests; figures are real time",
        "bus": f"nurimc sim --wire-timing, motors {IDS} at {BAUD} bps; nurimc ros2 --rate 50 holds the port",
    }
    with tempfile.TemporaryDirectory(dir="/tmp", prefix="nmcs") as folder:
        link = str(Path(folder) / "tty")
        with started([NURIMC, "sim", "--link", link, "--ids", IDS, "--baud", str(BAUD), "--wire-timing"]):
            common = [NURIMC, "--port", link, "--baud", str(BAUD)]
            with started([*common, "ros2", "--ids", IDS, "--namespace", ns, "--rate", "50"]) as bridge:
                deadline = time.monotonic() + 15
                while not states.poll() and time.monotonic() < deadline:
                    time.sleep(0.01)
                time.sleep(1.0)
                cpu0 = cpu_seconds(bridge.pid)
                alone, took = count_states(states, args.seconds)
                cpu_alone = (cpu_seconds(bridge.pid) - cpu0) / took
                mcap = str(Path(folder) / "bench.mcap")
                with (
                    started([*common, "dashboard", "--listen", "127.0.0.1:0"]),
                    started([*common, "--id", IDS, "watch", "--interval", "0.1"], ready=False),
                    started([*common, "--id", IDS, "record", "--mcap", mcap]),
                ):
                    time.sleep(1.0)
                    conn = connect(link, "service_bench")
                    assert conn is not None
                    clients = conn.call("clients", timeout=10)
                    cpu0 = cpu_seconds(bridge.pid)
                    shared, took = count_states(states, args.seconds)
                    cpu_shared = (cpu_seconds(bridge.pid) - cpu0) / took
                    latencies: list[float] = []
                    confirmed = True
                    attached = AttachedBus(conn, link, BAUD)
                    for _ in range(5):
                        for device_id in (1, 2):
                            attached.motor(device_id).run(30)
                        time.sleep(0.5)
                        start = time.monotonic()
                        stop = conn.call("estop", timeout=60)
                        latencies.append(time.monotonic() - start)
                        confirmed = confirmed and bool(stop["ok"]) and stop["stopped"] == [1, 2]
                        time.sleep(0.5)
                    attached.close()
    peer.close()
    result["joint_states"] = {
        "alone_hz": round(alone, 2),
        "with_console_watch_record_hz": round(shared, 2),
        "ratio": round(shared / alone, 3) if alone else None,
        "goal": ">= 0.9",
        "attached": sorted(str(c["program"]) for c in clients),
    }
    result["estop_from_attached_program_s"] = {
        "runs": len(latencies),
        "median": round(statistics.median(latencies), 3),
        "max": round(max(latencies), 3),
        "every_motor_read_back_off": confirmed,
        "what": "request on the holder's socket to its answer: broadcast, each motor told, read back off",
    }
    result["holder_cpu_percent_of_one_core"] = {
        "alone": round(100 * cpu_alone, 1),
        "with_three_clients": round(100 * cpu_shared, 1),
    }
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
