#!/usr/bin/env python3
"""Check one language against the shared vectors through its conformance program.

Usage: python3 conformance/check.py LANG [VECTOR_FILE ...]
Sends every vector's line to `conformance/run LANG` in one process (no newline after the
last one: a last unterminated line must be answered too) and compares each answer with
the vector's expectation (conformance/README.md, "Vectors"). Prints failures and
`N passed, N failed`.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent


def line_of(vector: dict[str, Any]) -> bytes:
    """The raw bytes of a vector's input line (without the newline)."""
    if "line_bytes" in vector:
        raw = bytes.fromhex(vector["line_bytes"])
    elif "line" in vector:
        raw = "".join(text * times for text, times in vector["line"]).encode("utf-8")
    else:
        raw = json.dumps(vector["input"]).encode("ascii")
    if b"\n" in raw:
        raise SystemExit(f"vector {vector['name']!r}: a line cannot hold a newline")
    return raw


def expand(value: Any) -> Any:
    """`{"$repeat": X, "times": N}` inside a list stands for N copies of X."""
    if isinstance(value, dict):
        return {k: expand(v) for k, v in value.items()}
    if isinstance(value, list):
        out: list[Any] = []
        for item in value:
            if isinstance(item, dict) and set(item) == {"$repeat", "times"}:
                out.extend([expand(item["$repeat"])] * item["times"])
            else:
                out.append(expand(item))
        return out
    return value


def comparable(answer: Any) -> Any:
    """`detail` of a bad_request answer is free text: it must be a string, its words do not count."""
    if isinstance(answer, dict) and answer.get("error") == "bad_request" and isinstance(answer.get("detail"), str):
        return {"error": "bad_request"}
    return answer


def same(got: Any, expect: Any) -> bool:
    """Equal as JSON values, and a zero's sign counts (`-0.0` is not `0`: conformance/README.md)."""
    if isinstance(expect, float) and isinstance(got, int | float) and not isinstance(got, bool):
        return got == expect and math.copysign(1.0, got) == math.copysign(1.0, expect)
    if isinstance(expect, dict) and isinstance(got, dict):
        return got.keys() == expect.keys() and all(same(got[k], expect[k]) for k in expect)
    if isinstance(expect, list) and isinstance(got, list):
        return len(got) == len(expect) and all(same(g, e) for g, e in zip(got, expect, strict=True))
    if isinstance(got, bool) or isinstance(expect, bool):
        return got is expect  # true is not 1
    return bool(got == expect)


def describe(raw: bytes) -> str:
    shown = raw if len(raw) <= 200 else raw[:120] + b"...(%d bytes)..." % len(raw) + raw[-40:]
    return shown.decode("utf-8", "backslashreplace")


def load(files: list[Path] | None = None) -> list[dict[str, Any]]:
    files = files or sorted((ROOT / "spec" / "vectors").glob("*.jsonl"))
    return [json.loads(line) for path in files for line in path.read_text().splitlines() if line.strip()]


def check(command: list[str], label: str, files: list[Path] | None = None) -> int:
    """Run every vector through `command` in one process; print failures; 0 if all pass."""
    vectors = load(files)
    lines = [line_of(v) for v in vectors]
    proc = subprocess.run(command, input=b"\n".join(lines), capture_output=True, timeout=600, check=False)
    answers = proc.stdout.split(b"\n")
    if answers and answers[-1] == b"":
        answers.pop()
    if proc.returncode != 0 or len(answers) != len(vectors):
        print(f"{label} exited {proc.returncode} after {len(answers)} of {len(vectors)} answers")
        print(proc.stderr.decode("utf-8", "replace")[-2000:])
        return 1
    failed = 0
    for vector, raw, line in zip(vectors, lines, answers, strict=True):
        try:
            got = json.loads(line)
        except (json.JSONDecodeError, UnicodeDecodeError):
            got = line
        if not same(comparable(got), expand(vector["expect"])):
            failed += 1
            if failed <= 20:
                shown = line if len(line) <= 300 else line[:300] + b"..."
                print(
                    f"FAIL {vector['name']}\n  input:  {describe(raw)}\n"
                    f"  expect: {json.dumps(vector['expect'])[:300]}\n  got:    {shown.decode('utf-8', 'replace')}"
                )
    print(f"{label}: {len(vectors) - failed} passed, {failed} failed")
    return 1 if failed else 0


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    lang, files = argv[0], [Path(p) for p in argv[1:]] or None
    return check([str(ROOT / "conformance" / "run"), lang], f"conformance {lang}", files)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
