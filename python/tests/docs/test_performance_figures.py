"""docs/performance.md quotes the robot-class and start-up benchmarks (issue 33): each phrase
below is built from the recorded JSON (benchmarks/results/robot.json, startup.json), rounded as
the doc rounds it, and must appear in the doc word for word, so a re-recorded benchmark and the
doc cannot drift apart."""

from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
TIMES = "\u00d7"  # the doc's multiplication sign
ROBOT = json.loads((ROOT / "benchmarks/results/robot.json").read_text(encoding="utf-8"))
STARTUP = json.loads((ROOT / "benchmarks/results/startup.json").read_text(encoding="utf-8"))
DOC = (ROOT / "docs/performance.md").read_text(encoding="utf-8")


def _r(value: float, decimals: int) -> str:
    return f"{value:.{decimals}f}"


def phrases() -> list[str]:
    free, held = ROBOT["unconstrained"], ROBOT["one_core_25_percent"]
    return [
        f"| `read_state()` rate ÷ bare pyserial | {_r(free['read_state_vs_bare_rate'], 2)} | "
        f"{_r(held['read_state_vs_bare_rate'], 2)} | ≥ 0.8 |",
        f"| CPU per request ÷ bare pyserial's | {_r(free['read_state_vs_bare_cpu'], 1)} "
        f"({free['read_state_cpu_us_per_request']:.0f} µs vs {free['bare_cpu_us_per_request']:.0f} µs) | "
        f"{_r(held['read_state_vs_bare_cpu'], 1)} ({held['read_state_cpu_us_per_request']:.0f} µs vs "
        f"{held['bare_cpu_us_per_request']:.0f} µs) | ≤ 2 |",
        f"`nurimc --help` {_r(STARTUP['vs_typer_rich']['help'], 2)}{TIMES} the time of",
        f"`--version` {_r(STARTUP['vs_typer_rich']['version'], 2)}{TIMES}",
    ]


def test_every_quoted_figure_is_the_recorded_one() -> None:
    missing = [p for p in phrases() if p not in DOC]
    assert missing == [], "docs/performance.md and benchmarks/results disagree:\n" + "\n".join(missing)


def test_the_constrained_run_says_how_it_was_held() -> None:
    held = ROBOT["one_core_25_percent"]["constraint"]
    assert held.startswith(("cgroup v2", "taskset")), held
    assert ("taskset + neighbours" in DOC) == held.startswith("taskset")
