#!/usr/bin/env python3
"""Benchmarks of `nurimc ros2`, each process as a user would run it, DDS on loopback only.

1. joint_states rate: `nurimc sim --wire-timing` on a pseudo-terminal, `nurimc ros2 --rate 0
   --broadcast-read` on it (the staggered group read: one broadcast request per reading), and
   an independent DDS subscriber counting joint_states; against the wire-limited reading rate.
   2 motors at 115200 bps, 8 motors at 1 Mbps; then the same with one request per motor.
2. Command-to-wire latency: a velocity command published by an independent participant until
   the bridge has written its frame to the port (the bridge records every frame it sends with
   `--mcap`; both stamps are the machine's wall clock). p50 / p99, bridge reading at 50 Hz.

3. The same two figures seen by a real ROS 2 node: rclpy Jazzy and Kilted from PyPI's wheels
   (`make ros-envs`; ros2_rclpy_node.py in build/ros-<release>/venv) counting joint_states and
   publishing velocity_commands.

Usage: python benchmarks/ros2_bench.py [--quick] [--rclpy-only]   (writes benchmarks/results/ros2.json;
--rclpy-only runs part 3 and replaces only its figures in that file)
"""

from __future__ import annotations

import json
import math
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
RESULTS = HERE / "results" / "ros2.json"
sys.path.insert(0, str(HERE.parent / "python" / "tests"))
os.environ["CYCLONEDDS_URI"] = (  # loopback only, as the tests
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery></Domain></CycloneDDS>"
)
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(100, 200)))

from mcap.reader import make_reader  # noqa: E402

from nurimc.procedures.group import stagger_slot  # noqa: E402
from nurimc.protocol import StreamParser  # noqa: E402
from nurimc.ros2.msgs import Frame  # noqa: E402
from ros2.peer import JointState, Peer, command  # noqa: E402 - the tests' independent participant

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
BITS = 10  # per byte on the wire: start, 8 data, stop
REQUEST, ANSWER = 6, 12  # bytes of a position request and of its answer


def wire_limit_broadcast(motors: int, baud: int) -> float:
    """Readings per second if only the wire took time: the request, the staggered answers, the last one."""
    slot = stagger_slot(baud) * 100e-6
    return 1.0 / (REQUEST * BITS / baud + motors * slot + ANSWER * BITS / baud)


def wire_limit_sequential(motors: int, baud: int, response: float = 100e-6) -> float:
    return 1.0 / (motors * ((REQUEST + ANSWER) * BITS / baud + response))


def ready_line(process: subprocess.Popen[str], timeout: float = 30) -> str:
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
def started(argv: list[str]) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True, env={**os.environ, "NO_COLOR": "1"})
    try:
        yield process
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(15)
        except subprocess.TimeoutExpired:
            process.kill()


@contextmanager
def simulator(ids: list[int], baud: int) -> Iterator[str]:
    argv = [NURIMC, "sim", "--ids", ",".join(map(str, ids)) + ",", "--baud", str(baud), "--wire-timing"]
    with started(argv) as sim:
        yield ready_line(sim).split("ready:", 1)[1].strip()


def process_cpu(pid: int) -> float:
    """CPU seconds (user + system) a process has used so far, from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def joint_states_rate(
    motors: int, baud: int, seconds: float, broadcast: bool = True, dds: str = "rtps"
) -> dict[str, object]:
    ids = list(range(1, motors + 1))
    ns = f"/bench{motors}{'b' if broadcast else 's'}{dds}"
    peer = Peer()
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    with simulator(ids, baud) as pty:
        argv = [NURIMC, "--port", pty, "--baud", str(baud), "ros2", "--ids", ",".join(map(str, ids))]
        read = ["--broadcast-read"] if broadcast else []
        with started([*argv, "--namespace", ns, "--rate", "0", "--dds", dds, *read]) as bridge:
            ready_line(bridge)
            deadline = time.monotonic() + 10
            while not states.poll() and time.monotonic() < deadline:
                time.sleep(0.01)
            time.sleep(0.5)  # warm up
            before = len(states.poll())
            start = time.monotonic()
            cpu_before = process_cpu(bridge.pid)
            while time.monotonic() - start < seconds:
                states.poll()  # often: the reader keeps the last 10 only (ROS 2's default QoS)
                time.sleep(0.005)
            window = states.poll()[before:]
            elapsed = time.monotonic() - start
            cpu = process_cpu(bridge.pid) - cpu_before
    peer.close()
    received = len(window)
    complete = sum(1 for s in window if len(s.name) == motors)
    rate = received / elapsed
    limit = wire_limit_broadcast(motors, baud) if broadcast else wire_limit_sequential(motors, baud)
    return {
        "motors": motors,
        "baud": baud,
        "read": "staggered broadcast (--broadcast-read)" if broadcast else "one request per motor (default)",
        "joint_states_per_s": round(rate, 1),
        "wire_limit_per_s": round(limit, 1),
        "fraction_of_wire": round(rate / limit, 3),
        "complete_per_s": round(complete / elapsed, 1),
        "fraction_complete": round(complete / received, 4),
        "seconds": round(elapsed, 2),
        "dds": dds,
        "bridge_cpu_fraction": round(cpu / elapsed, 3),  # of one core
        "bridge_cpu_ms_per_joint_state": round(1000 * cpu / max(received, 1), 3),
    }


def command_latency(commands: int) -> dict[str, float]:
    baud, ns = 1_000_000, "/latency"
    peer = Peer()
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    velocities = peer.publisher(f"{ns}/velocity_commands", type(command([])))
    sent: dict[int, int] = {}  # wire speed value (0.1 RPM) -> when the command was published (ns)
    with tempfile.TemporaryDirectory() as folder, simulator([1], baud) as pty:
        recording = Path(folder) / "latency.mcap"
        argv = [NURIMC, "--port", pty, "--baud", str(baud), "ros2", "--ids", "1", "--namespace", ns]
        with started([*argv, "--rate", "50", "--command-timeout", "0", "--mcap", str(recording)]) as bridge:
            ready_line(bridge)
            while not states.poll():
                time.sleep(0.01)
            time.sleep(0.5)  # let discovery match our writer
            for k in range(commands):
                rpm = 10.0 + 0.1 * (k % 2000)  # every command a different speed, so its frame is told apart
                sent[round(rpm * 10)] = time.time_ns()
                velocities.write(command([rpm * 2 * math.pi / 60]))
                time.sleep(random.uniform(0.005, 0.015))  # between readings at random phases
            time.sleep(0.5)
        latencies = []
        with recording.open("rb") as stream:
            for _, _channel, message in make_reader(stream).iter_messages(topics=["/nurimc/frames"]):
                frame = Frame.deserialize(message.data)
                if frame.direction == "tx" and frame.name == "accel_speed":
                    speed = StreamParser().feed(bytes(frame.data))[0].fields()["speed"]
                    if speed in sent:
                        latencies.append((message.log_time - sent.pop(speed)) / 1e6)
    peer.close()
    latencies.sort()
    return {
        "commands": commands,
        "frames_matched": len(latencies),
        "p50_ms": round(statistics.median(latencies), 3),
        "p99_ms": round(latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))], 3),
        "max_ms": round(latencies[-1], 3),
        "bridge_reading_hz": 50,
        "baud": baud,
    }


ROS_ENVS = HERE.parent / "build"
RCLPY_NODE = HERE / "ros2_rclpy_node.py"
FASTDDS_LOOPBACK = HERE.parent / "python" / "tests" / "ros2" / "rclpy_node" / "fastdds_loopback.xml"


def rclpy_node(release: str, mode: str, ns: str, amount: float) -> dict[str, object]:
    python = ROS_ENVS / f"ros-{release}" / "venv" / "bin" / "python"
    if not python.exists():
        raise SystemExit(f"no ROS 2 {release} environment at {python}: run `make ros-envs`")
    env = {
        **os.environ,
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "FASTDDS_DEFAULT_PROFILES_FILE": str(FASTDDS_LOOPBACK),
    }
    argv = [str(python), str(RCLPY_NODE), mode, ns, str(amount)]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=300, env=env, check=True)
    return dict(json.loads(proc.stdout.strip().splitlines()[-1]))


def rclpy_joint_states_rate(release: str, motors: int, baud: int, seconds: float) -> dict[str, object]:
    ids = list(range(1, motors + 1))
    ns = f"/rclpy_{release}_{motors}"
    with simulator(ids, baud) as pty:
        argv = [NURIMC, "--port", pty, "--baud", str(baud), "ros2", "--ids", ",".join(map(str, ids))]
        with started([*argv, "--namespace", ns, "--rate", "0", "--broadcast-read"]) as bridge:
            ready_line(bridge)
            seen = rclpy_node(release, "rate", ns, seconds)
    rate = float(seen["received"]) / float(seen["seconds"])  # type: ignore[arg-type]
    limit = wire_limit_broadcast(motors, baud)
    return {
        "motors": motors,
        "baud": baud,
        "read": "staggered broadcast (--broadcast-read)",
        "subscriber": f"rclpy {release} (Fast DDS), default QoS",
        "joint_states_per_s": round(rate, 1),
        "wire_limit_per_s": round(limit, 1),
        "fraction_of_wire": round(rate / limit, 3),
        "seconds": round(float(seen["seconds"]), 2),  # type: ignore[arg-type]
    }


def rclpy_command_latency(release: str, commands: int) -> dict[str, object]:
    baud, ns = 1_000_000, f"/rclpy_latency_{release}"
    with tempfile.TemporaryDirectory() as folder, simulator([1], baud) as pty:
        recording = Path(folder) / "latency.mcap"
        argv = [NURIMC, "--port", pty, "--baud", str(baud), "ros2", "--ids", "1", "--namespace", ns]
        with started([*argv, "--rate", "50", "--command-timeout", "0", "--mcap", str(recording)]) as bridge:
            ready_line(bridge)
            sent = {int(k): int(v) for k, v in rclpy_node(release, "latency", ns, commands)["sent"].items()}  # type: ignore[union-attr]
            time.sleep(0.5)
        latencies = []
        with recording.open("rb") as stream:
            for _, _channel, message in make_reader(stream).iter_messages(topics=["/nurimc/frames"]):
                frame = Frame.deserialize(message.data)
                if frame.direction == "tx" and frame.name == "accel_speed":
                    speed = StreamParser().feed(bytes(frame.data))[0].fields()["speed"]
                    if speed in sent:
                        latencies.append((message.log_time - sent.pop(speed)) / 1e6)
    latencies.sort()
    return {
        "publisher": f"rclpy {release} (Fast DDS), default QoS",
        "commands": commands,
        "frames_matched": len(latencies),
        "p50_ms": round(statistics.median(latencies), 3),
        "p99_ms": round(latencies[min(len(latencies) - 1, int(0.99 * len(latencies)))], 3),
        "max_ms": round(latencies[-1], 3),
        "bridge_reading_hz": 50,
        "baud": baud,
    }


def rclpy_results(quick: bool) -> dict[str, dict[str, object]]:
    seconds, commands = (2.0, 200) if quick else (8.0, 1000)
    results = {}
    for release in ("jazzy", "kilted"):
        results[f"rclpy_{release}_joint_states_2_motors_115200"] = rclpy_joint_states_rate(release, 2, 115_200, seconds)
        results[f"rclpy_{release}_joint_states_8_motors_1Mbps"] = rclpy_joint_states_rate(
            release, 8, 1_000_000, seconds
        )
        results[f"rclpy_{release}_command_to_wire_latency"] = rclpy_command_latency(release, commands)
    return results


def main() -> None:
    quick = "--quick" in sys.argv
    if "--rclpy-only" in sys.argv:
        rclpy = rclpy_results(quick)
        print(json.dumps(rclpy, indent=2))
        if not quick:
            record = json.loads(RESULTS.read_text())
            record["results"].update(rclpy)
            record["rclpy_date"] = time.strftime("%Y-%m-%d")
            RESULTS.write_text(json.dumps(record, indent=2) + "\n")
            print(f"written: {RESULTS}")
        return
    seconds = 2.0 if quick else 8.0
    results = {
        "joint_states_2_motors_115200": joint_states_rate(2, 115_200, seconds),
        "joint_states_8_motors_1Mbps": joint_states_rate(8, 1_000_000, seconds),
        "joint_states_2_motors_115200_sequential": joint_states_rate(2, 115_200, seconds, broadcast=False),
        "joint_states_8_motors_1Mbps_sequential": joint_states_rate(8, 1_000_000, seconds, broadcast=False),
        # the same bridge on Cyclone DDS (--dds cyclone), side by side in this run
        "joint_states_8_motors_1Mbps_cyclone": joint_states_rate(8, 1_000_000, seconds, dds="cyclone"),
        "joint_states_8_motors_1Mbps_sequential_cyclone": joint_states_rate(
            8, 1_000_000, seconds, broadcast=False, dds="cyclone"
        ),
        "command_to_wire_latency": command_latency(200 if quick else 1000),
        **rclpy_results(quick),
    }
    print(json.dumps(results, indent=2))
    if not quick:
        record = {
            "results": results,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "cores": os.cpu_count(),
            "date": time.strftime("%Y-%m-%d"),
            "setup": "nurimc sim --wire-timing (pseudo-terminal), nurimc ros2, subscriber: "
            "3 processes, DDS on loopback",
        }
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
