from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nurimc.procedures.stepresponse import analyse


def test_rise_time_and_overshoot_of_an_upward_step() -> None:
    times = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
    positions = [0.0, 15.0, 50.0, 95.0, 110.0, 100.0]
    figures = analyse(times, positions, 0.0, 100.0)
    assert figures.rise_time == pytest.approx(0.2)  # 10 % at 0.1 s, 90 % at 0.3 s
    assert figures.overshoot == pytest.approx(10.0)
    assert figures.settled and figures.final_error == 0


def test_a_downward_step_is_measured_the_same_way() -> None:
    figures = analyse([0.0, 0.1, 0.2, 0.3], [30.0, 20.0, 5.0, 10.0], 30.0, 10.0)
    assert figures.rise_time == pytest.approx(0.1)
    assert figures.overshoot == pytest.approx(25.0)


def test_a_step_that_never_arrives_has_no_rise_time() -> None:
    figures = analyse([0.0, 1.0], [0.0, 50.0], 0.0, 100.0)
    assert figures.rise_time is None and not figures.settled and figures.final_error == 50.0


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="different start and target"):
        analyse([0.0], [1.0], 1.0, 1.0)
    with pytest.raises(ValueError, match="as many times as positions"):
        analyse([0.0, 1.0], [1.0], 0.0, 1.0)


def _shared_cases() -> list[dict[str, Any]]:
    path = Path(__file__).resolve().parents[3] / "spec" / "vectors" / "step-figures.json"
    cases: list[dict[str, Any]] = json.loads(path.read_text(encoding="utf-8"))["cases"]
    return cases


@pytest.mark.parametrize("case", _shared_cases(), ids=lambda case: str(case["name"]))
def test_the_shared_step_figure_vectors(case: dict[str, Any]) -> None:
    """spec/vectors/step-figures.json: the one definition the TypeScript library and the page run too."""
    args = (case["times"], case["positions"], case["start"], case["target"])
    if case.get("error"):
        with pytest.raises(ValueError):
            analyse(*args)
        return
    figures, expect = analyse(*args), case["expect"]
    for mine, theirs in ((figures.rise_time, expect["rise"]), (figures.settling_time, expect["settling"])):
        assert (mine is None) == (theirs is None)
        if mine is not None:
            assert mine == pytest.approx(theirs, abs=1e-9)
    assert figures.overshoot == pytest.approx(expect["overshoot"], abs=0.005)
    assert figures.final_error == pytest.approx(expect["final_error"], abs=0.0005)
    assert figures.settled is expect["settled"]
