#!/usr/bin/env python3
"""The request path on a robot-class computer (issue 33): the library against bare pyserial,
measured from outside, unconstrained and with the measured process held to one core at 25 %.

The simulator runs in its own process (`python -m nurimc.sim --link ... --wire-timing`, eight
controllers at 1 Mbps): it is the wire, never constrained. Each measured loop runs in a fresh
worker process (this file with --worker KIND), alone on the link, for --seconds; rounds alternate
the kinds, so a busy moment of the (shared) machine slows all of them. A worker reports what it
did, the wall time and its own CPU time (user + system), so the figures are:

- rate ratio: the library's requests/s ÷ bare pyserial's (median of the rounds' own ratios);
- CPU per request, and its ratio to bare pyserial's;
- group of 8 and the ROS 2 bridge's joint_states loop ÷ the wire limit (one request + answer per
  motor at 1 Mbps, 10 bits a byte, the simulator's 100 us response time).

Held to one core at 25 %: through cgroup v2 `cpu.max` (25000 100000) when a child group can be made,
else `taskset` to one core with three busy neighbour processes on the same core (each gets a fair
quarter); the result says which ("constraint"). Bare pyserial is held the same way.

Usage: python benchmarks/robot_bench.py [--quick] [--seconds S] [--rounds N]
(writes benchmarks/results/robot.json unless --quick)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "robot.json"
RATE = 1_000_000
IDS = list(range(1, 9))
WIRE_BITS = 10
RESPONSE = 100e-6  # the simulator's default response time
#: one request (6 bytes) and its answer (12 bytes) on the wire, plus the response time
WIRE_REQUEST = (6 + 12) * WIRE_BITS / RATE + RESPONSE
CGROUP = Path("/sys/fs/cgroup")


# -- the measured loops (run in the worker process) ---------------------------------------------
def _loop(seconds: float, one: Callable[[], int]) -> dict[str, Any]:
    for _ in range(50):  # warm up (caches, the simulator's first answers)
        one()
    done = failed = 0
    cpu0, start = time.process_time(), time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        ok = one()
        done += 1
        failed += not ok
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu0
    return {"cycles": done, "failed": failed, "wall": wall, "cpu": cpu}


def worker(kind: str, link: str, seconds: float) -> dict[str, Any]:
    if kind in ("bare", "bare8"):
        import serial

        port = serial.Serial(link, RATE, timeout=0.05)
        from nurimc.protocol import RequestPosition  # only its bytes: the loop is pure pyserial

        frames = [RequestPosition(i).encode() for i in IDS]
        ids = [0] if kind == "bare" else list(range(8))

        def bare() -> int:
            ok = 1
            for i in ids:
                port.write(frames[i])
                ok &= len(port.read(12)) == 12
            return ok

        return _loop(seconds, bare)
    from nurimc import Bus, Group, MotorState

    bus = Bus.open(link, baudrate=RATE)
    if kind == "state":
        motor = bus.motor(1)

        def state() -> int:
            try:
                motor.read_state()
            except Exception:
                return 0
            return 1

        return _loop(seconds, state)
    if kind == "group":
        group = Group(bus, IDS)

        def states() -> int:
            return all(isinstance(v, MotorState) for v in group.read_states().values())

        return _loop(seconds, states)
    assert kind == "bridge"
    os.environ["CYCLONEDDS_URI"] = (  # loopback only, as the tests and ros2_bench.py
        "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General></Domain></CycloneDDS>"
    )
    os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
    from nurimc.ros2.bridge import Bridge
    from nurimc.ros2.dds import Participant
    from nurimc.ros2.node import BridgeNode

    bridge = Bridge(tuple(IDS), tuple(f"joint{i}" for i in IDS))
    node = BridgeNode(bus, bridge, Participant(), rate=0.0, log=lambda _: None)
    node.prepare(discovery_wait=0.0)

    def publish() -> int:
        return node.read_and_publish() is not None and not any(j.error for j in node.bridge.joints)

    return _loop(seconds, publish)


# -- the constraint -----------------------------------------------------------------------------
def cgroup_v2() -> Path | None:
    """A child cgroup v2 group with cpu.max 25 % of one core, or None if one cannot be made here."""
    if not (CGROUP / "cgroup.controllers").exists():
        return None
    try:
        own = Path("/proc/self/cgroup").read_text().split("::", 1)[1].strip()
        group = CGROUP / own.lstrip("/") / f"nurimc-bench-{os.getpid()}"
        group.mkdir()
        (group / "cpu.max").write_text("25000 100000\n")
        return group
    except (OSError, IndexError):
        return None


@contextlib.contextmanager
def held(how: str) -> Iterator[Callable[[list[str]], list[str]]]:
    """Yields a function that wraps a worker command line so it runs held as `how` says."""
    if how == "none":
        yield lambda cmd: cmd
        return
    if how == "cgroup-v2":
        group = cgroup_v2()
        assert group is not None
        procs = group / "cgroup.procs"
        try:
            yield lambda cmd: ["sh", "-c", f'echo $$ > {procs} && exec "$@"', "held", *cmd]
        finally:
            with contextlib.suppress(OSError):
                group.rmdir()
        return
    core = str(max(os.sched_getaffinity(0)))
    neighbours = [subprocess.Popen(["taskset", "-c", core, sys.executable, "-c", "while True: pass"]) for _ in range(3)]
    try:
        yield lambda cmd: ["taskset", "-c", core, *cmd]
    finally:
        for n in neighbours:
            n.kill()
            n.wait()


def run_worker(wrap: Callable[[list[str]], list[str]], kind: str, link: str, seconds: float) -> dict[str, Any]:
    cmd = wrap(
        [sys.executable, str(Path(__file__).resolve()), "--worker", kind, "--link", link, "--seconds", str(seconds)]
    )
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds + 60)
    if out.returncode != 0:
        raise SystemExit(f"worker {kind} failed: {out.stderr.strip()[-2000:]}")
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


@contextlib.contextmanager
def simulator(directory: str) -> Iterator[str]:
    link = os.path.join(directory, "bus")
    cmd = [
        sys.executable,
        "-m",
        "nurimc.sim",
        "--link",
        link,
        "--baud",
        str(RATE),
        "--ids",
        ",".join(map(str, IDS)),
        "--wire-timing",
    ]
    sim = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    try:
        assert sim.stdout is not None
        for line in sim.stdout:
            if line.startswith("ready:"):
                break
        else:
            raise SystemExit("the simulator did not start")
        yield link
    finally:
        sim.terminate()
        sim.wait(10)


def phase(how: str, link: str, kinds: list[str], rounds: int, seconds: float) -> dict[str, list[dict[str, Any]]]:
    runs: dict[str, list[dict[str, Any]]] = {k: [] for k in kinds}
    with held(how) as wrap:
        for r in range(rounds):
            order = kinds if r % 2 == 0 else kinds[::-1]
            for kind in order:
                runs[kind].append(run_worker(wrap, kind, link, seconds))
    return runs


def summarise(runs: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    def rate(r: dict[str, Any], per: int = 1) -> float:
        return float(r["cycles"] * per / r["wall"])

    def cpu_us(r: dict[str, Any], per: int = 1) -> float:
        return float(r["cpu"] / (r["cycles"] * per) * 1e6)

    out: dict[str, Any] = {}
    bare, state = runs["bare"], runs["state"]
    out["bare_requests_per_s"] = round(statistics.median(rate(r) for r in bare), 1)
    out["read_state_requests_per_s"] = round(statistics.median(rate(r) for r in state), 1)
    out["read_state_vs_bare_rate"] = round(
        statistics.median(rate(s) / rate(b) for s, b in zip(state, bare, strict=True)), 3
    )
    out["read_state_vs_bare_rate_rounds"] = [round(rate(s) / rate(b), 3) for s, b in zip(state, bare, strict=True)]
    out["bare_cpu_us_per_request"] = round(statistics.median(cpu_us(r) for r in bare), 1)
    out["read_state_cpu_us_per_request"] = round(statistics.median(cpu_us(r) for r in state), 1)
    out["read_state_vs_bare_cpu"] = round(
        statistics.median(cpu_us(s) / cpu_us(b) for s, b in zip(state, bare, strict=True)), 3
    )
    out["wire_limit_requests_per_s"] = round(1 / WIRE_REQUEST, 1)
    if "group" in runs:
        group = runs["group"]
        out["group8_reads_per_s"] = round(statistics.median(rate(r) for r in group), 1)
        out["group8_vs_wire"] = round(statistics.median(rate(r, 8) * WIRE_REQUEST for r in group), 3)
        out["group8_cpu_us_per_request"] = round(statistics.median(cpu_us(r, 8) for r in group), 1)
    if "bare8" in runs:
        out["bare8_vs_wire"] = round(statistics.median(rate(r, 8) * WIRE_REQUEST for r in runs["bare8"]), 3)
    if "bridge" in runs:
        bridge = runs["bridge"]
        out["bridge_joint_states_per_s"] = round(statistics.median(rate(r) for r in bridge), 1)
        out["bridge_vs_wire"] = round(statistics.median(rate(r, 8) * WIRE_REQUEST for r in bridge), 3)
        out["bridge_cpu_us_per_request"] = round(statistics.median(cpu_us(r, 8) for r in bridge), 1)
        out["bridge_cpu_share"] = round(statistics.median(r["cpu"] / r["wall"] for r in bridge), 3)
    out["failed"] = {k: sum(r["failed"] for r in v) for k, v in runs.items()}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a short run that writes nothing")
    parser.add_argument("--seconds", type=float, default=2.0, help="seconds per worker run")
    parser.add_argument("--rounds", type=int, default=7, help="alternating rounds per phase")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--link", help=argparse.SUPPRESS)
    parser.add_argument("--no-bridge", action="store_true", help="leave out the ROS 2 bridge loop")
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.link, args.seconds)))
        return
    seconds, rounds = (1.0, 3) if args.quick else (args.seconds, args.rounds)
    if cgroup_v2_usable():
        how = "cgroup-v2"
    elif shutil.which("taskset"):
        how = "taskset"
    else:
        raise SystemExit("neither a writable cgroup v2 nor taskset: cannot hold the process to one core")
    kinds = ["bare", "state", "bare8", "group"] + ([] if args.no_bridge else ["bridge"])
    result: dict[str, Any] = {
        "benchmark": "robot_bench",
        "link": f"nurimc sim --link pty, 8 controllers at {RATE} bps, wire timing on (separate process)",
        "seconds_per_run": seconds,
        "rounds": rounds,
        "host": {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count()},
        "note": "shared 2-core host, busy with other work during the run (up to 9 agents)",
        "load_average_at_start": [round(x, 1) for x in os.getloadavg()],
    }
    with tempfile.TemporaryDirectory() as directory, simulator(directory) as link:
        for name, mode in (("unconstrained", "none"), ("one_core_25_percent", how)):
            t0 = time.perf_counter()
            figures = summarise(phase(mode, link, kinds, rounds, seconds))
            figures["constraint"] = {
                "none": "none",
                "cgroup-v2": "cgroup v2 cpu.max 25000 100000",
                "taskset": "taskset to one core + 3 busy neighbour processes on it (a fair quarter each)",
            }[mode]
            result[name] = figures
            print(f"{name} ({time.perf_counter() - t0:.0f} s): {json.dumps(figures)}", flush=True)
    result["load_average_at_end"] = [round(x, 1) for x in os.getloadavg()]
    if not args.quick:
        RESULTS.write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {RESULTS}")


def cgroup_v2_usable() -> bool:
    group = cgroup_v2()
    if group is None:
        return False
    with contextlib.suppress(OSError):
        group.rmdir()
    return True


if __name__ == "__main__":
    main()
