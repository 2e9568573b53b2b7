"""docs/performance.md quotes the TypeScript and C request-path benchmark (issue 33, item 5): each
phrase below is built from the recorded JSON (benchmarks/results/request-path.json), rounded as the
doc rounds it, and must appear in the doc word for word, as test_performance_figures.py does for
robot.json, so a re-recorded benchmark and the doc cannot drift apart."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[3]
DASH = "\u2013"  # the doc's range dash
RESULT = json.loads((ROOT / "benchmarks/results/request-path.json").read_text(encoding="utf-8"))
DOC = (ROOT / "docs/performance.md").read_text(encoding="utf-8")
ROWS = {
    "typescript": "TypeScript `motor.readState()` ÷ bare `serialport`",
    "c": "C `nurimc_bus_query()` ÷ bare `read()`/`write()`",
    "python": "Python `read_state()` ÷ bare pyserial (for reference)",
}


def _cell(language: dict[str, Any]) -> str:
    rounds = language["library_vs_bare_rate_rounds"]
    return (
        f"{language['library_vs_bare_rate']:.2f} ({min(rounds):.2f}{DASH}{max(rounds):.2f}); "
        f"{language['library_vs_bare_cpu']:.1f} ({language['library_cpu_us_per_request']:.0f} µs vs "
        f"{language['bare_cpu_us_per_request']:.0f} µs)"
    )


def phrases() -> list[str]:
    free, held = RESULT["unconstrained"], RESULT["one_core_25_percent"]
    return [f"| {ROWS[name]} | {_cell(free[name])} | {_cell(held[name])} |" for name in ROWS if name in free]


def test_every_quoted_figure_is_the_recorded_one() -> None:
    found = phrases()
    assert len(found) == len(ROWS), "request-path.json lacks a language the doc quotes"
    missing = [p for p in found if p not in DOC]
    assert missing == [], "docs/performance.md and request-path.json disagree:\n" + "\n".join(missing)


def test_the_constrained_run_says_how_it_was_held() -> None:
    held = RESULT["one_core_25_percent"]["constraint"]
    assert held.startswith(("cgroup v2", "taskset")), held
    section = DOC.split("## The request path in TypeScript and C", 1)[1].split("\n## ", 1)[0]
    assert ("taskset + neighbours" in section) == held.startswith("taskset")
