#!/usr/bin/env python3
"""Micro-benchmark of the Python protocol layer: frames/s for encode, decode, stream parsing.

Usage: python benchmarks/protocol_bench.py [--quick]
Prints a table and writes benchmarks/results/protocol-python.json. Not a test: figures
vary with the machine; the results file records the machine next to them.
"""

from __future__ import annotations

import json
import platform
import random
import sys
import time
from pathlib import Path

from nurimc.protocol import SPECS, StreamParser, decode, make

RESULTS = Path(__file__).resolve().parent / "results" / "protocol-python.json"


def sample_messages(count: int) -> list:
    rng = random.Random(1)
    names = sorted(SPECS)
    out = []
    for _ in range(count):
        spec = SPECS[rng.choice(names)]
        fields = {f.name: rng.randint(f.min, f.max) for f in spec.fields}
        out.append(make(spec.name, rng.randint(0, spec.max_id), **fields))
    return out


def best_rate(fn, items: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return items / best


def main() -> None:
    quick = "--quick" in sys.argv
    messages = sample_messages(2_000 if quick else 20_000)
    frames = [m.encode() for m in messages]
    stream = b"".join(frames)
    chunks = [stream[i : i + 64] for i in range(0, len(stream), 64)]
    repeat = 3 if quick else 5

    def parse() -> None:
        parser = StreamParser()
        for chunk in chunks:
            parser.feed(chunk)

    results = {
        "encode_frames_per_s": best_rate(lambda: [m.encode() for m in messages], len(messages), repeat),
        "decode_frames_per_s": best_rate(lambda: [decode(f) for f in frames], len(frames), repeat),
        "parse_frames_per_s": best_rate(parse, len(frames), repeat),
        "parse_MB_per_s": best_rate(parse, len(stream), repeat) / 1e6,
    }
    wire_max = 1_000_000 / 10 / (sum(map(len, frames)) / len(frames))
    results["wire_frames_per_s_at_1Mbps"] = wire_max
    for key, value in results.items():
        print(f"{key:32s} {value:14,.1f}")
    record = {
        "results": {k: round(v, 1) for k, v in results.items()},
        "frames": len(frames),
        "python": platform.python_version(),
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "date": time.strftime("%Y-%m-%d"),
    }
    if not quick:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
