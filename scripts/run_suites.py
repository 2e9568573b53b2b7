"""Run every test suite of `make test`, even after one fails, and end with one summary.

`make test` calls this with the suite targets in order. Each suite runs as `make -k TARGET` (so a
suite's own sub-steps also all run), its output goes to the terminal as it comes and to
build/test-logs/TARGET.log. At the end one table: suite, result, passed/failed/skipped (when the
suite's tools print them: pytest, node --test), time. Exit 1 if any suite failed.

    python scripts/run_suites.py check-generated lint test-python ...
    python scripts/run_suites.py --list-only ...   # print the plan, run nothing
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LOGS = ROOT / "build" / "test-logs"

# pytest: "3 failed, 120 passed, 4 skipped, 1 xfailed in 12.34s" (any order, any subset)
PYTEST_LINE = re.compile(
    r"^=*\s*((?:\d+ (?:passed|failed|skipped|errors?|xfailed|xpassed|deselected)[, ]*)+)\s+in\s+[\d.]+s"
)
PYTEST_ITEM = re.compile(r"(\d+) (passed|failed|skipped|errors?|xfailed|xpassed)")
# node --test (TAP or spec reporter; the spec reporter starts lines with U+2139): "# pass 12", "# skipped 1"
NODE_ITEM = re.compile(r"^(?:#|\u2139)\s+(pass|fail|skipped|skip|todo|cancelled)\s+(\d+)\s*$")


# vitest: " Tests  119 passed | 1 skipped (120)"
VITEST_LINE = re.compile(r"^Tests\s+((?:\d+ (?:passed|failed|skipped|todo)\s*\|?\s*)+)\(\d+\)$")
VITEST_ITEM = re.compile(r"(\d+) (passed|failed|skipped|todo)")
# ctest: "100% tests passed, 0 tests failed out of 23"
CTEST_LINE = re.compile(r"^\d+% tests passed, (\d+) tests failed out of (\d+)")


@dataclass
class Counts:
    passed: int = 0
    failed: int = 0
    skipped: int = 0
    seen: bool = False

    def add_line(self, line: str) -> None:
        text = line.strip()
        m = PYTEST_LINE.match(text)
        if m:
            for n, kind in PYTEST_ITEM.findall(m.group(1)):
                self._add(kind, int(n))
            return
        m = NODE_ITEM.match(text)
        if m:
            self._add(m.group(1), int(m.group(2)))
            return
        m = VITEST_LINE.match(text)
        if m:
            for n, kind in VITEST_ITEM.findall(m.group(1)):
                self._add(kind, int(n))
            return
        m = CTEST_LINE.match(text)
        if m:
            failed, total = int(m.group(1)), int(m.group(2))
            self._add("passed", total - failed)
            self._add("failed", failed)

    def _add(self, kind: str, n: int) -> None:
        self.seen = True
        if kind in ("passed", "pass", "xfailed"):
            self.passed += n
        elif kind in ("failed", "fail", "error", "errors", "xpassed", "cancelled"):
            self.failed += n
        elif kind in ("skipped", "skip", "todo"):
            self.skipped += n


@dataclass
class Result:
    suite: str
    code: int = 0
    seconds: float = 0.0
    counts: Counts = field(default_factory=Counts)


def run_suite(suite: str, make: str) -> Result:
    result = Result(suite)
    LOGS.mkdir(parents=True, exist_ok=True)
    log_path = LOGS / f"{suite}.log"
    print(f"\n===== {suite} =====", flush=True)
    start = time.monotonic()
    with log_path.open("w", encoding="utf-8") as log:
        proc = subprocess.Popen(
            [make, "--no-print-directory", "-k", suite],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            errors="replace",
            bufsize=1,
        )
        assert proc.stdout is not None
        for line in proc.stdout:
            sys.stdout.write(line)
            log.write(line)
            result.counts.add_line(line)
        result.code = proc.wait()
    result.seconds = time.monotonic() - start
    sys.stdout.flush()
    return result


def fmt_time(seconds: float) -> str:
    minutes, secs = divmod(round(seconds), 60)
    return f"{minutes}m{secs:02d}s" if minutes else f"{seconds:.1f}s"


def summary(results: list[Result], total: float) -> str:
    rows = [("suite", "result", "passed", "failed", "skipped", "time")]
    for r in results:
        c = r.counts
        nums = (str(c.passed), str(c.failed), str(c.skipped)) if c.seen else ("-", "-", "-")
        rows.append((r.suite, "ok" if r.code == 0 else f"FAILED ({r.code})", *nums, fmt_time(r.seconds)))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["", "===== make test: summary ====="]
    for row in rows:
        lines.append("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    failed = [r.suite for r in results if r.code != 0]
    totals = Counts()
    for r in results:
        totals.passed += r.counts.passed
        totals.failed += r.counts.failed
        totals.skipped += r.counts.skipped
    lines.append(
        f"{len(results)} suites, {len(results) - len(failed)} ok, {len(failed)} failed; "
        f"tests counted: {totals.passed} passed, {totals.failed} failed, {totals.skipped} skipped; "
        f"total {fmt_time(total)}"
    )
    if failed:
        lines.append(f"FAILED: {' '.join(failed)} (logs in {LOGS.relative_to(ROOT)}/SUITE.log)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("suites", nargs="+", help="make targets, run in this order")
    parser.add_argument("--list-only", action="store_true", help="print the plan and run nothing")
    args = parser.parse_args(argv)
    if args.list_only:
        print("\n".join(args.suites))
        return 0
    make = os.environ.get("MAKE", "make")
    start = time.monotonic()
    results: list[Result] = []
    try:
        for suite in args.suites:
            results.append(run_suite(suite, make))
    except KeyboardInterrupt:
        print(summary(results, time.monotonic() - start))
        print("interrupted")
        return 130
    print(summary(results, time.monotonic() - start))
    return 1 if any(r.code != 0 for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
