#!/usr/bin/env python3
"""Run the C benchmark natively (frames/s, the library against hand-written baselines in the
same run) and under callgrind (instructions per frame); record the results in
benchmarks/results/c-bench.json. See docs/performance.md.

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
PHASES = (
    "bench_decode",
    "bench_encode",
    "bench_feed",
    "bench_memchr_feed",
    "bench_push",
    "bench_push_checked",
    "bench_naive_push",
    "bench_push_floor",
)
NATIVE_FRAMES = 2_000_000
CALLGRIND_FRAMES = 20_000
# library phase -> (its baseline phase, the key of each in the native results)
RATIOS = {
    "push_vs_naive_state_machine": ("parse_push_frames_per_s", "baseline_naive_push_frames_per_s"),
    "push_checked_vs_naive_state_machine": ("parse_push_checked_frames_per_s", "baseline_naive_push_frames_per_s"),
    "feed_vs_memchr_parser": ("parse_feed_frames_per_s", "baseline_memchr_feed_frames_per_s"),
}


def instructions(exe: str, phase: str) -> float:
    """Instructions per frame of one phase (only that function and its callees are counted),
    over one round of CALLGRIND_FRAMES frames."""
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
                "1",
            ],
            check=True,
            capture_output=True,
            text=True,
        )
        summary = re.search(r"^(?:summary|totals): (\d+)", out.read_text(), re.MULTILINE)
        if summary is None:
            raise SystemExit(f"no instruction count in the callgrind output of {phase}")
        return int(summary.group(1)) / CALLGRIND_FRAMES


def main(exe: str) -> int:
    native = json.loads(subprocess.run([exe, str(NATIVE_FRAMES)], check=True, capture_output=True, text=True).stdout)
    per_frame = {phase.removeprefix("bench_"): round(instructions(exe, phase), 1) for phase in PHASES}
    cc = subprocess.run(["cc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    result = {
        "benchmark": "c/bench/bench.c via c/bench/run_bench.py (make -f c/Makefile.inc bench)",
        "date": datetime.now(UTC).strftime("%Y-%m-%d"),
        "machine": f"{platform.machine()}, {platform.processor() or 'unknown cpu'}, one core",
        "compiler": f"{cc}, -O3 (CMake Release)",
        "native": native,
        "ratios": {name: round(native[ours] / native[base], 3) for name, (ours, base) in RATIOS.items()},
        "instructions_per_frame_callgrind": per_frame,
        "notes": "frames are all 42 message types in turn, mid-range values, back to back; feed = 256-byte "
        "reads through nurimc_parser_feed; push = one byte at a time through nurimc_parser_push (a static "
        "inline function: it stores a byte that needs no look and calls out of line for the others, about "
        "three per frame: FF, the mode byte, the last byte); push_checked = the same through the exported "
        "out-of-line nurimc_parser_push_checked, a call per byte. Baselines (same run, interleaved rounds, "
        "best round of each, thread CPU time): naive_push = a hand-written byte state machine (FF, FE, size "
        "byte, collect, nurimc_decode; a call per byte), memchr_feed = a hand-written memchr parser (memchr "
        "to FF, check FE and size, nurimc_decode). Ratio = library frames/s over baseline frames/s (above 1: "
        "the library is faster). Instructions per frame count the phase's whole loop; push_floor is that byte "
        "loop calling a function that only keeps the byte (no parsing): the floor of any parser with a call "
        "per byte. A 1 Mbps wire carries at most about 13,300 frames/s.",
    }
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
