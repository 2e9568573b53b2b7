"""The smaller first-hour items of issue 38: watch's time column, record's ready line matching
its options, and the like."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from typing import Any

import pytest

from nurimc.cli.zero_cmd import zero_here

from .inprocess import nurimc


def test_watch_to_a_pipe_has_a_time_column() -> None:
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "watch", "--count", "3", "--interval", "0.05")
    assert done.code == 0, done.err
    header, *lines = done.out.splitlines()
    assert header.split("\t")[-1] == "t (s)" and len(lines) == 3
    times = [float(line.split("\t")[-1]) for line in lines]
    assert times == sorted(times) and times[-1] - times[0] >= 0.1  # two intervals of 0.05 s at least


def test_get_takes_several_names() -> None:
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "get", "ratio", "resolution", "id")
    assert done.code == 0, done.err
    assert done.out.splitlines() == ["ratio = 1:1", "resolution = 4", "id = 1"]
    as_json = json.loads(nurimc("--port", "sim://?ids=1", "--id", "1", "--json", "get", "ratio", "baud").out)
    assert [(r["name"], r["value"]) for r in as_json] == [("ratio", 1.0), ("baud", 9600)]


def test_get_of_one_name_is_unchanged() -> None:
    assert nurimc("--port", "sim://?ids=1", "--id", "1", "get", "ratio").out == "ratio = 1:1\n"
    one = json.loads(nurimc("--port", "sim://?ids=1", "--id", "1", "--json", "get", "ratio").out)
    assert one["name"] == "ratio" and one["value"] == 1.0


def test_get_checks_every_name_before_it_reads() -> None:
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "get", "ratio", "nope")
    assert done.code == 2 and done.out == "" and "unknown setting 'nope'" in done.err


def test_set_help_does_not_offer_read_only_settings() -> None:
    shown = " ".join(nurimc("set", "--help").out.split())
    assert "position-kp" in shown and "firmware" not in shown
    assert "firmware" in " ".join(nurimc("get", "--help").out.split())


def test_set_zero_makes_the_present_position_zero(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    _, bus = make_sim_bus([1], resolution=1024)
    motor = bus.motor(1)
    motor.move_to(90, rpm=120, wait=True)
    assert abs(motor.read_state().device_position - 90) < 1
    state = bus.run(zero_here(bus.core, motor.procedures))
    assert abs(state.device_position) < 1 and abs(motor.read_state().position) < 1


def test_set_zero_command() -> None:
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "set-zero")
    assert done.code == 0 and done.out == "ID 1: the present position is now 0° (verified)\n", done.err


def test_a_move_that_cannot_arrive_at_the_factory_resolution_says_so() -> None:
    # sim:// controllers keep the document's factory resolution, 4: positions in 22.5° steps
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "move", "100", "--rpm", "120", "--wait", "--timeout", "2")
    assert done.code == 1 and len(done.errors) == 1, done.err
    assert "its resolution is the factory 4, so it reads positions in 22.5° steps" in done.err
    assert "set resolution 1024" in done.err


def test_demo_prints_no_python_dict() -> None:
    done = nurimc("demo", "--seconds", "1")
    assert done.code == 0, done.err
    line = next(x for x in done.out.replace("\n", " ").split("released all motors.")[1:])
    assert "Bus statistics: requests " in line and "{" not in line and "'" not in line.split("nurimc")[0]


@pytest.mark.parametrize(
    ("args", "korean"),
    [
        (("move", "1000"), "각도: '1000'은(는) 범위를 벗어났습니다"),
        (("run", "99999"), "회전 속도: '99999'은(는) 범위를 벗어났습니다"),
    ],
)
def test_korean_errors_name_the_argument_in_korean(
    monkeypatch: pytest.MonkeyPatch, args: tuple[str, ...], korean: str
) -> None:
    monkeypatch.setenv("LANGUAGE", "ko")
    done = nurimc("--port", "sim://?ids=1", "--id", "1", *args)
    assert done.code == 2 and korean in done.err, done.err
    assert not re.search(r"\b(degrees|rpm)\b", done.err), done.err
