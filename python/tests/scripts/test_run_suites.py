"""scripts/run_suites.py, what `make test` runs (issue 38): every suite runs even after one fails,
one summary at the end with the counts the suites' tools print, exit 1 if any failed. A fake
`make` (the MAKE variable) stands in for the real suites."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts/run_suites.py"

FAKE_MAKE = """#!/bin/bash
# the last argument is the suite
case "${@: -1}" in
  py-ok)   echo "12 passed, 2 skipped in 0.50s" ;;
  py-bad)  echo "1 failed, 4 passed in 0.20s"; exit 2 ;;
  node-ok) printf '# pass 7\\n# fail 0\\n# skipped 1\\n' ;;
  vitest)  echo " Tests  9 passed | 1 skipped (10)" ;;
  quiet)   echo "built" ;;
esac
"""


def run(tmp_path: Path, *suites: str) -> subprocess.CompletedProcess[str]:
    make = tmp_path / "make"
    make.write_text(FAKE_MAKE)
    make.chmod(0o755)
    env = {**os.environ, "MAKE": str(make)}
    return subprocess.run([sys.executable, str(SCRIPT), *suites], capture_output=True, text=True, env=env, timeout=120)


def summary_rows(out: str) -> dict[str, list[str]]:
    table = out.split("===== make test: summary =====", 1)[1].strip().splitlines()
    return {
        line.split()[0]: line.split()
        for line in table[1:]
        if line.split() and not line[0].isdigit() and not line.startswith("FAILED")
    }


def test_every_suite_runs_after_a_failure_and_the_summary_counts(tmp_path: Path) -> None:
    done = run(tmp_path, "py-ok", "py-bad", "node-ok", "vitest", "quiet")
    assert done.returncode == 1, done.stderr
    rows = summary_rows(done.stdout)
    assert list(rows) == ["py-ok", "py-bad", "node-ok", "vitest", "quiet"]
    assert rows["py-ok"][1:5] == ["ok", "12", "0", "2"]
    assert rows["py-bad"][1:6] == ["FAILED", "(2)", "4", "1", "0"]
    assert rows["node-ok"][1:5] == ["ok", "7", "0", "1"]
    assert rows["vitest"][1:5] == ["ok", "9", "0", "1"]
    assert rows["quiet"][1:5] == ["ok", "-", "-", "-"]  # no counts printed: none claimed
    assert "5 suites, 4 ok, 1 failed; tests counted: 32 passed, 1 failed, 4 skipped" in done.stdout
    assert "FAILED: py-bad" in done.stdout
    assert (ROOT / "build/test-logs/py-bad.log").read_text().startswith("1 failed, 4 passed")


def test_all_green_exits_0(tmp_path: Path) -> None:
    done = run(tmp_path, "py-ok", "node-ok")
    assert done.returncode == 0 and "2 suites, 2 ok, 0 failed" in done.stdout


def test_the_makefile_runs_every_suite_through_it() -> None:
    makefile = (ROOT / "Makefile").read_text()
    suites = makefile.split("TEST_SUITES :=", 1)[1].splitlines()[0].split()
    assert suites == [
        "check-generated", "lint", "test-python", "fuzz-python-short", "conformance", "test-c",
        "test-embedded", "test-sigrok", "test-ts", "test-e2e", "test-dist",
    ]  # fmt: skip
    assert "scripts/run_suites.py $(TEST_SUITES)" in makefile
