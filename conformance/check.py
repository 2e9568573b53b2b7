#!/usr/bin/env python3
"""Check one language against the shared vectors through its conformance program.

Usage: python3 conformance/check.py LANG [VECTOR_FILE ...]
Sends every vector's input to `conformance/run LANG` in one process and compares each
answer with the vector's expectation. Prints failures and `N passed, N failed`.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    lang, files = argv[0], [Path(p) for p in argv[1:]] or sorted((ROOT / "spec" / "vectors").glob("*.jsonl"))
    vectors = [json.loads(line) for path in files for line in path.read_text().splitlines() if line.strip()]
    stdin = "".join(json.dumps(v["input"]) + "\n" for v in vectors)
    proc = subprocess.run(
        [str(ROOT / "conformance" / "run"), lang], input=stdin, capture_output=True, text=True, timeout=600
    )
    answers = proc.stdout.splitlines()
    if proc.returncode != 0 or len(answers) != len(vectors):
        print(f"conformance/run {lang} exited {proc.returncode} after {len(answers)} of {len(vectors)} answers")
        print(proc.stderr[-2000:])
        return 1
    failed = 0
    for vector, line in zip(vectors, answers):
        try:
            got = json.loads(line)
        except json.JSONDecodeError:
            got = line
        if got != vector["expect"]:
            failed += 1
            if failed <= 20:
                print(f"FAIL {vector['name']}\n  input:  {json.dumps(vector['input'])}\n"
                      f"  expect: {json.dumps(vector['expect'])}\n  got:    {line}")
    print(f"conformance {lang}: {len(vectors) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
