"""What people read: status rows with one name each and a unit in every value that has one;
`bench` keeps the source tree's recorded results untouched unless --record asks."""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import pytest

from nurimc.procedures.settings import SETTINGS

from .inprocess import assert_clean, nurimc

ROOT = Path(__file__).resolve().parents[3]
SIM = "sim://?ids=0,1"


def _rows(text: str) -> dict[str, list[str]]:
    rows: dict[str, list[str]] = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("│ ").split("│")]
        if len(cells) == 2 and cells[0] and cells[0] not in ("reading", "setting"):
            rows.setdefault(cells[0], []).append(cells[1])
    return rows


def test_status_names_each_row_once_with_its_unit() -> None:
    result = nurimc("--port", SIM, "--id", "1", "status")
    assert_clean(result)
    rows = _rows(result.out)
    assert [name for name, values in rows.items() if len(values) > 1] == []  # no two rows named alike
    assert set(SETTINGS) <= set(rows)
    shown = {name: values[0] for name, values in rows.items()}
    assert shown["response-time"] == "100 µs" and shown["rated-speed"] == "3000 RPM"
    assert shown["position-rated-current"] == "5 A" and shown["ratio"] == "1:1" and shown["position"] == "0°"
    assert shown["direction"] == "ccw" and shown["position sign"].startswith("ccw (")  # a setting, a reading
    for name, value in shown.items():
        unit = (
            {"A": " A", "us": " µs", "rpm": " RPM", "ratio": ":1"}.get(SETTINGS[name].spec.unit, "")
            if name in SETTINGS
            else ""
        )
        assert value.endswith(unit), (name, value)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()} if folder.is_dir() else {}


@pytest.mark.parametrize("record", [False, True])
def test_bench_records_only_when_asked(record: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each benchmark script is run (here: a stand-in that writes its results file next to itself,
    as the real ones do) from a scratch copy unless --record; the source tree's results stay."""
    results = ROOT / "benchmarks" / "results"
    before = _snapshot(results)
    ran: list[Path] = []

    def fake_run(argv: list[str], check: bool = False, **_: Any) -> subprocess.CompletedProcess[str]:
        script = Path(argv[1])
        ran.append(script)
        if not record:
            (script.parent / "results" / "written.json").write_text("{}")  # as a script would
        return subprocess.CompletedProcess(argv, 0)

    monkeypatch.setattr(subprocess, "run", fake_run)  # what nurimc.cli.demo calls
    result = nurimc("bench", "--record") if record else nurimc("bench", "--quick")
    assert_clean(result)
    assert result.code == 0 and len(ran) == len(list((ROOT / "benchmarks").glob("*.py"))) > 0
    if record:
        assert all(script.parent == ROOT / "benchmarks" for script in ran), ran
        assert "recorded in" in result.out, result.out
    else:
        assert all(ROOT not in script.parents for script in ran) and "nothing recorded" in result.out
        assert not ran[0].exists()  # the scratch folder is gone
    assert _snapshot(results) == before
