"""Every figure docs/library.md quotes comes from the recorded results
(benchmarks/results/library.json, and wire.json for lost and late answers): each phrase below
is built from the JSON, rounded as the doc rounds it, and must appear in the doc word for word.
Re-recording the benchmark without updating the doc (or the other way round) fails here."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[3]
RESULTS = json.loads((ROOT / "benchmarks/results/library.json").read_text(encoding="utf-8"))["results"]
RESULTS["wire"] = json.loads((ROOT / "benchmarks/results/wire.json").read_text(encoding="utf-8"))["results"]
LIBRARY_MD = (ROOT / "docs/library.md").read_text(encoding="utf-8")

CYCLE = "control_cycle_8_motors_1Mbps"
REAL = "wire.cycles_real_time"  # lost answers: the fence rule (docs/protocol.md, Stale answers)
VIRTUAL = "wire.cycles_virtual_time"
INTEGRITY = "integrity_issue_10"

#: (phrase with one {} per figure, [(path in the results, decimals), ...])
PHRASES: list[tuple[str, list[tuple[str, int]]]] = [
    ("about {} ms per transaction here", [("latency.library_median_us", -1)]),
    (
        "ratio {} ({} µs vs {} µs median)",
        [("latency.ratio", 2), ("latency.library_median_us", 0), ("latency.bare_pyserial_median_us", 0)],
    ),
    ("| {} s | < 15 s |", [("discovery.seconds", 1)]),
    ("3 controllers at unknown rates among the 18: {} s with wire", [("discovery.seconds", 1)]),
    (
        "{} cycles/s = {} of the wire maximum | ≥ 0.8",
        [(f"{CYCLE}.broadcast_cycles_per_s", 0), (f"{CYCLE}.broadcast_fraction_of_wire", 2)],
    ),
    ("reach {} of the wire-limited cycle rate", [(f"{CYCLE}.broadcast_fraction_of_wire", 2)]),
    (
        "{} cycles/s = {} of the wire maximum; bare pyserial on the same pty: {}/s",
        [
            (f"{CYCLE}.sequential_cycles_per_s", 0),
            (f"{CYCLE}.sequential_fraction_of_wire", 2),
            (f"{CYCLE}.bare_pyserial_cycles_per_s", 0),
        ],
    ),
    (
        "one request per motor: {} of the wire limit; staggered broadcast: {} ({} without losses in the same run; "
        "on virtual time {} and {}); {} stale values",
        [
            (f"{REAL}.3%_lost.sequential.fraction_of_wire", 2),
            (f"{REAL}.3%_lost.broadcast.fraction_of_wire", 2),
            (f"{REAL}.0%_lost.broadcast.fraction_of_wire", 2),
            (f"{VIRTUAL}.3%_lost.sequential.fraction_of_wire", 2),
            (f"{VIRTUAL}.3%_lost.broadcast.fraction_of_wire", 2),
            (f"{REAL}.3%_lost.broadcast.stale_values", 0),
        ],
    ),
    (
        "{} stale values ({} answers late)",
        [("wire.late_single_reads_115200.stale_values", 0), ("wire.late_single_reads_115200.answers_late", 0)],
    ),
    (
        "{} stale values ({} answers delayed, {} late frames dropped)",
        [
            (f"{INTEGRITY}.late_answers_200_reads.stale_values", 0),
            (f"{INTEGRITY}.late_answers_200_reads.answers_delayed", 0),
            (f"{INTEGRITY}.late_answers_200_reads.stale_frames_dropped", 0),
        ],
    ),
    (
        "{} short results ({} answers lost",
        [
            (f"{INTEGRITY}.broadcast_300_reads_3pct_missed.short_results", 0),
            (f"{INTEGRITY}.broadcast_300_reads_3pct_missed.answers_missed", 0),
        ],
    ),
]


def figure(path: str, decimals: int) -> str:
    value: Any = RESULTS
    for key in path.split("."):
        value = value[key]
    if decimals < 0:  # µs quoted in ms, to one decimal
        return f"{value / 1000:.1f}"
    return f"{value:.{decimals}f}"


def test_every_quoted_figure_is_the_recorded_one() -> None:
    wrong = []
    for template, paths in PHRASES:
        phrase = template.format(*(figure(p, d) for p, d in paths))
        if phrase not in LIBRARY_MD:
            wrong.append(phrase)
    assert wrong == [], f"docs/library.md does not say (as the results do): {wrong}"


def test_no_figure_of_the_table_is_left_unchecked() -> None:
    """Every number with a unit in the benchmark table is one the phrases above check."""
    start = LIBRARY_MD.index("## Benchmarks")
    end = LIBRARY_MD.find("\n## ", start + 1)
    table = LIBRARY_MD[start : end if end >= 0 else None]
    checked = " ".join(t.format(*(figure(p, d) for p, d in ps)) for t, ps in PHRASES)
    quoted = re.findall(r"(\d+(?:\.\d+)?) (?:cycles/s|ms|µs|s\b)", table)
    goals = {"15", "0.8", "60"}  # goals, and the conditions a row sets (answers 60 ms late)
    assert [q for q in quoted if q not in checked and q not in goals] == []
