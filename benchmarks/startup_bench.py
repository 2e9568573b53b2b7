#!/usr/bin/env python3
"""CLI start-up (issue 33): `nurimc --help`, `nurimc --version` and `nurimc status --help` against
`python -c "import typer, rich"` alone, each a fresh process, in alternating rounds (a busy moment of
the shared machine slows all of them); the ratio is the median of the rounds' own ratios.

Usage: python benchmarks/startup_bench.py [--quick]   (writes benchmarks/results/startup.json)
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results" / "startup.json"
NURIMC = [sys.executable, "-c", "from nurimc.cli.app import main; main()"]
CASES = {
    "typer_rich_import": [sys.executable, "-c", "import typer, rich"],
    "help": [*NURIMC, "--help"],
    "version": [*NURIMC, "--version"],
    "status_help": [*NURIMC, "status", "--help"],
}


def main() -> None:
    quick = "--quick" in sys.argv[1:]
    rounds = 3 if quick else 15
    load_start = [round(x, 1) for x in os.getloadavg()]
    seconds: dict[str, list[float]] = {name: [] for name in CASES}
    for r in range(rounds):
        names = list(CASES) if r % 2 == 0 else list(CASES)[::-1]
        for name in names:
            start = time.perf_counter()
            subprocess.run(CASES[name], stdout=subprocess.DEVNULL, check=True)
            seconds[name].append(time.perf_counter() - start)
    base = seconds["typer_rich_import"]
    result = {
        "benchmark": "startup_bench",
        "rounds": rounds,
        "median_seconds": {name: round(statistics.median(v), 3) for name, v in seconds.items()},
        "vs_typer_rich": {
            name: round(statistics.median(a / b for a, b in zip(v, base, strict=True)), 2)
            for name, v in seconds.items()
            if name != "typer_rich_import"
        },
        "note": "shared 2-core host, busy with other work during the run (up to 9 agents)",
        "load_average": {"start": load_start, "end": [round(x, 1) for x in os.getloadavg()]},
    }
    print(json.dumps(result, indent=2))
    if not quick:
        RESULTS.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
