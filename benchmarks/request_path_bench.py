#!/usr/bin/env python3
"""The request path of the TypeScript and C libraries on a robot-class computer (issue 33, item 5):
each library's read-state loop against the least a program can do in its language, measured from
outside, unconstrained and with the measured process held to one core at 25 %.

The method is robot_bench.py's (its constraint helpers are imported from it). The simulator runs
in its own process (`python -m nurimc.sim --link ... --wire-timing`, one controller, ID 1, at
1 Mbps): it is the wire, never constrained. Each measured loop is a fresh process, alone on the
link, for --seconds after warm-up requests (50; Node: 500, while V8 compiles); rounds alternate
the kinds (order reversed every other round), so a busy moment of the (shared) machine slows all
of them. Kinds:

- ts-library: `motor.readState()` on the TypeScript `Bus` over `NodeSerialPort` (Node);
- ts-bare: the `serialport` package alone: write the 6-byte request, wait for the 12 answer bytes;
- c-library: `nurimc_bus_query(REQUEST_POSITION)` of the C POSIX host layer, answer in degrees;
- c-bare: a blocking raw fd: write() the 6 bytes, read() until the 12 bytes are in;
- py-library, py-bare: robot_bench.py's `read_state()` and bare pyserial workers, for reference.

Workers: ts/benchmarks/request_path.mjs (CPU: process.cpuUsage) and c/bench/request_path.c
(CPU: CLOCK_PROCESS_CPUTIME_ID), both user + system time of the whole process. Figures per
language: requests/s and CPU per request of each loop, and the library's ÷ the bare loop's
(medians of the rounds' own ratios).

Usage: python benchmarks/request_path_bench.py [--quick] [--seconds S] [--rounds N] [--languages ts,c,py]
(builds the TS dist/ and the C worker first; writes benchmarks/results/request-path.json unless --quick)
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
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
import robot_bench  # noqa: E402  (the constraint and worker helpers of the Python benchmark)

RESULTS = HERE / "results" / "request-path.json"
RATE = robot_bench.RATE
ID = 1
C_BUILD = ROOT / "c" / "build"
C_WORKER = C_BUILD / "nurimc_request_path"
TS_WORKER = ROOT / "ts" / "benchmarks" / "request_path.mjs"
LANGUAGES = {"ts": "typescript", "c": "c", "py": "python"}
CONSTRAINTS = {
    "none": "none",
    "cgroup-v2": "cgroup v2 cpu.max 25000 100000",
    "taskset": "taskset to one core + 3 busy neighbour processes on it (a fair quarter each)",
}


def build(languages: list[str]) -> None:
    """The TS dist/ (tsc) and the C worker (CMake, the repository's -Werror flags), fresh."""
    steps: list[tuple[list[str], Path]] = []
    if "ts" in languages:
        if not (ROOT / "ts" / "node_modules").is_dir():
            raise SystemExit("ts/node_modules is missing: run `cd ts && npm ci` first")
        steps.append((["npx", "tsc", "-p", "."], ROOT / "ts"))
    if "c" in languages:
        steps.append(
            (["cmake", "-S", "c", "-B", str(C_BUILD), "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release"], ROOT),
        )
        steps.append((["cmake", "--build", str(C_BUILD), "--target", "nurimc_request_path"], ROOT))
    for cmd, cwd in steps:
        out = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
        if out.returncode != 0:
            raise SystemExit(f"{' '.join(cmd)} failed:\n{(out.stdout + out.stderr).strip()[-2000:]}")


def command(kind: str, link: str, seconds: float) -> list[str]:
    language, loop = kind.split("-")
    if language == "ts":
        return ["node", str(TS_WORKER), loop, link, str(seconds)]
    if language == "c":
        return [str(C_WORKER), loop, link, str(seconds)]
    worker = {"library": "state", "bare": "bare"}[loop]
    return [sys.executable, str(HERE / "robot_bench.py"), "--worker", worker, "--link", link, "--seconds", str(seconds)]


def run_worker(wrap: Callable[[list[str]], list[str]], kind: str, link: str, seconds: float) -> dict[str, Any]:
    out = subprocess.run(wrap(command(kind, link, seconds)), capture_output=True, text=True, timeout=seconds + 60)
    if out.returncode != 0:
        raise SystemExit(f"worker {kind} failed: {out.stderr.strip()[-2000:]}")
    return dict(json.loads(out.stdout.strip().splitlines()[-1]))


@contextlib.contextmanager
def simulator(directory: str) -> Iterator[str]:
    """One controller (ID 1) at 1 Mbps with wire timing, on a pseudo-terminal; yields its link."""
    link = os.path.join(directory, "bus")
    cmd = [sys.executable, "-m", "nurimc.sim", "--link", link, "--baud", str(RATE), "--ids", str(ID), "--wire-timing"]
    sim = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
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
    with robot_bench.held(how) as wrap:
        for r in range(rounds):
            for kind in kinds if r % 2 == 0 else kinds[::-1]:
                runs[kind].append(run_worker(wrap, kind, link, seconds))
    return runs


def summarise(library: list[dict[str, Any]], bare: list[dict[str, Any]]) -> dict[str, Any]:
    def rate(r: dict[str, Any]) -> float:
        return float(r["cycles"] / r["wall"])

    def cpu_us(r: dict[str, Any]) -> float:
        return float(r["cpu"] / r["cycles"] * 1e6)

    pairs = list(zip(library, bare, strict=True))
    return {
        "bare_requests_per_s": round(statistics.median(rate(r) for r in bare), 1),
        "library_requests_per_s": round(statistics.median(rate(r) for r in library), 1),
        "library_vs_bare_rate": round(statistics.median(rate(lib) / rate(b) for lib, b in pairs), 3),
        "library_vs_bare_rate_rounds": [round(rate(lib) / rate(b), 3) for lib, b in pairs],
        "bare_cpu_us_per_request": round(statistics.median(cpu_us(r) for r in bare), 1),
        "library_cpu_us_per_request": round(statistics.median(cpu_us(r) for r in library), 1),
        "library_vs_bare_cpu": round(statistics.median(cpu_us(lib) / cpu_us(b) for lib, b in pairs), 3),
        "library_vs_bare_cpu_rounds": [round(cpu_us(lib) / cpu_us(b), 3) for lib, b in pairs],
        "failed": {"library": sum(r["failed"] for r in library), "bare": sum(r["failed"] for r in bare)},
    }


def versions(languages: list[str]) -> dict[str, Any]:
    host: dict[str, Any] = {"python": platform.python_version(), "machine": platform.machine(), "cpus": os.cpu_count()}
    if "ts" in languages:
        host["node"] = subprocess.run(["node", "--version"], capture_output=True, text=True).stdout.strip()
        package = json.loads((ROOT / "ts" / "node_modules" / "serialport" / "package.json").read_text())
        host["serialport"] = package["version"]
    if "c" in languages:
        cache = (C_BUILD / "CMakeCache.txt").read_text()
        compilers = [line.split("=", 1)[1] for line in cache.splitlines() if line.startswith("CMAKE_C_COMPILER:")]
        compiler = compilers[0] if compilers else "cc"
        host["cc"] = subprocess.run([compiler, "--version"], capture_output=True, text=True).stdout.split("\n")[0]
    return host


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="writes nothing; 0.5 s runs, 1 round unless given")
    parser.add_argument("--seconds", type=float, help="seconds per worker run (default 2)")
    parser.add_argument("--rounds", type=int, help="alternating rounds per phase (default 9)")
    parser.add_argument("--languages", default="ts,c,py", help="comma-separated: ts, c, py (default all three)")
    parser.add_argument("--note", default="shared 2-core host, busy with other work during the run (6 agents)")
    args = parser.parse_args()
    languages = [x.strip() for x in args.languages.split(",") if x.strip()]
    unknown = [x for x in languages if x not in LANGUAGES]
    if unknown or not languages:
        raise SystemExit(f"--languages {args.languages!r}: use a comma-separated list of ts, c, py")
    seconds = args.seconds if args.seconds is not None else 0.5 if args.quick else 2.0
    rounds = args.rounds if args.rounds is not None else 1 if args.quick else 9
    if seconds <= 0 or rounds < 1:
        raise SystemExit("--seconds must be > 0 and --rounds at least 1")
    if robot_bench.cgroup_v2_usable():
        how = "cgroup-v2"
    elif shutil.which("taskset"):
        how = "taskset"
    else:
        raise SystemExit("neither a writable cgroup v2 nor taskset: cannot hold the process to one core")
    build(languages)
    kinds = [f"{language}-{loop}" for language in languages for loop in ("library", "bare")]
    result: dict[str, Any] = {
        "benchmark": "request_path_bench",
        "link": f"nurimc sim --link pty, 1 controller (ID 1) at {RATE} bps, wire timing on (separate process)",
        "request": "request_position (6 bytes) + its answer (12 bytes)",
        "seconds_per_run": seconds,
        "rounds": rounds,
        "host": versions(languages),
        "note": args.note,
        "load_average_at_start": [round(x, 1) for x in os.getloadavg()],
    }
    with tempfile.TemporaryDirectory() as directory, simulator(directory) as link:
        for name, mode in (("unconstrained", "none"), ("one_core_25_percent", how)):
            t0 = time.perf_counter()
            runs = phase(mode, link, kinds, rounds, seconds)
            figures: dict[str, Any] = {"constraint": CONSTRAINTS[mode]}
            for language in languages:
                figures[LANGUAGES[language]] = summarise(runs[f"{language}-library"], runs[f"{language}-bare"])
            result[name] = figures
            print(f"{name} ({time.perf_counter() - t0:.0f} s): {json.dumps(figures)}", flush=True)
    result["load_average_at_end"] = [round(x, 1) for x in os.getloadavg()]
    if not args.quick:
        RESULTS.write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
