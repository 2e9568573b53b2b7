#!/usr/bin/env python3
"""Run every shared vector through one conformance executable (e.g. the sanitizer build).

Usage: run_vectors.py EXECUTABLE — like conformance/check.py, but with an explicit program.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(exe: str) -> int:
    vectors = [
        json.loads(line)
        for path in sorted((ROOT / "spec" / "vectors").glob("*.jsonl"))
        for line in path.read_text().splitlines()
        if line.strip()
    ]
    stdin = "".join(json.dumps(v["input"]) + "\n" for v in vectors)
    proc = subprocess.run([exe], input=stdin, capture_output=True, text=True, timeout=300)
    answers = proc.stdout.splitlines()
    if proc.returncode != 0 or len(answers) != len(vectors):
        print(f"{exe} exited {proc.returncode} after {len(answers)} of {len(vectors)} answers\n{proc.stderr[-3000:]}")
        return 1
    failed = [v["name"] for v, line in zip(vectors, answers) if json.loads(line) != v["expect"]]
    for name in failed[:20]:
        print(f"FAIL {name}")
    print(f"{len(vectors) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
