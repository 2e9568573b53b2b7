#!/usr/bin/env python3
"""Run the C benchmark natively (frames/s) and under callgrind (instructions per frame);
record the results in benchmarks/results/c-bench.json.

Usage: run_bench.py BENCH_EXECUTABLE
"""

from __future__ import annotations

import json
import platform
import re
import subprocess
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RESULT = ROOT / "benchmarks" / "results" / "c-bench.json"
PHASES = ("bench_decode", "bench_encode", "bench_feed", "bench_push")
CALLGRIND_FRAMES = 20000


def instructions(exe: str, phase: str) -> float:
    """Instructions per frame of one phase (only that function and its callees are counted).

    Each phase runs five times over CALLGRIND_FRAMES frames (best of five natively)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(
            [
                "valgrind",
                "--tool=callgrind",
                f"--callgrind-out-file={out}",
                f"--toggle-collect={phase}",
                exe,
                str(CALLGRIND_FRAMES),
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        summary = re.search(r"^(?:summary|totals): (\d+)", out.read_text(), re.MULTILINE)
        if summary is None:
            raise SystemExit(f"no instruction count in the callgrind output of {phase}")
        return int(summary.group(1)) / (5 * CALLGRIND_FRAMES)


def main(exe: str) -> int:
    native = json.loads(subprocess.run([exe, "2000000"], check=True, capture_output=True, text=True).stdout)
    per_frame = {phase.removeprefix("bench_"): round(instructions(exe, phase), 1) for phase in PHASES}
    cc = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    result = {
        "benchmark": "c/bench/bench.c via c/bench/run_bench.py (make -f c/Makefile.inc bench)",
        "date": datetime.now(UTC).strftime("%Y-%m-%d"),
        "machine": f"{platform.machine()}, {platform.processor() or 'unknown cpu'}, one core",
        "compiler": f"{cc}, -O3 (CMake Release)",
        "native": native,
        "instructions_per_frame_callgrind": per_frame,
        "notes": "frames are all 42 message types in turn, mid-range values, back to back; feed = 256-byte "
        "reads through nurimc_parser_feed; push = one byte at a time through nurimc_parser_push. "
        "A 1 Mbps wire carries at most about 13,300 frames/s.",
    }
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
