"""Shared IDs (issue 38 New motors, issue 39 item 3): found and explained, never made by us.

Two new controllers both come as ID 0 at 9600 bps; on one bus their answers collide. Virtual
time, in-process simulator (tests/client/simfixtures.py); the CLI in-process (tests/cli/inprocess.py)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from nurimc.errors import IdInUse
from nurimc.procedures import config
from nurimc.procedures.collisions import IdShared, who_answers

from ..cli.inprocess import nurimc

ADVICE = "connect one at a time, then give each an ID"


def ids_of(sim: Any) -> list[tuple[int, int]]:
    return sorted((c.settings.id, c.baud) for c in sim.controllers)


def test_who_answers_tells_none_one_and_shared(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    _sim, bus = make_sim_bus([0, 0, 5])
    assert bus.run(who_answers(bus.core, 0)) == "shared"
    assert bus.run(who_answers(bus.core, 5)) == "one"
    assert bus.run(who_answers(bus.core, 9)) == "none"


def test_set_id_on_a_shared_id_is_refused_and_writes_nothing(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus([0, 0])
    before = ids_of(sim)
    with pytest.raises(IdShared, match=ADVICE):
        bus.run(config.change_id(bus.core, 0, 1))
    assert ids_of(sim) == before == [(0, 9600), (0, 9600)]


def test_set_id_to_an_id_that_answers_is_refused(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus([1, 2])
    with pytest.raises(IdInUse, match="ID 2 already answers"):
        bus.run(config.change_id(bus.core, 1, 2))
    assert ids_of(sim) == [(1, 9600), (2, 9600)]


def test_set_baud_checks_the_target_rate_first(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus({3: 9600})
    sim.add_controller(id=3, baud=115200)  # the same ID, at the rate asked for
    with pytest.raises(IdInUse, match=r"already answers at 115200 bps.*share it; nothing was written"):
        bus.run(config.change_baud(bus.core, 3, 115200))
    assert ids_of(sim) == [(3, 9600), (3, 115200)]
    assert bus.baudrate == 9600  # the host is back at its rate
    assert bus.run(config.change_baud(bus.core, 3, 57600)) == 57600  # a free rate: done
    assert ids_of(sim) == [(3, 57600), (3, 115200)]


def test_set_baud_on_a_shared_id_is_refused(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus([4, 4])
    with pytest.raises(IdShared, match=ADVICE):
        bus.run(config.change_baud(bus.core, 4, 57600))
    assert ids_of(sim) == [(4, 9600), (4, 9600)]


def test_factory_reset_refused_when_id_0_at_9600_answers(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus({0: 9600, 3: 57600})
    bus.baudrate = 57600
    with pytest.raises(IdInUse, match="two controllers would share ID 0"):
        bus.run(config.factory_reset(bus.core, 3, confirm=True))
    assert ids_of(sim) == [(0, 9600), (3, 57600)]
    assert bus.baudrate == 57600
    bus.run(config.factory_reset(bus.core, 3, confirm=True, allow_shared=True))  # asked for explicitly
    bus.clock.sleep(0.2)
    assert ids_of(sim) == [(0, 9600), (0, 9600)]


def test_factory_reset_goes_ahead_on_a_free_factory_id(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus([3])
    bus.run(config.factory_reset(bus.core, 3, confirm=True))
    bus.clock.sleep(0.2)
    assert ids_of(sim) == [(0, 9600)]


def test_factory_reset_of_id_0_at_9600_is_not_a_collision(make_sim_bus: Callable[..., tuple[Any, Any]]) -> None:
    sim, bus = make_sim_bus([0])
    bus.run(config.factory_reset(bus.core, 0, confirm=True))
    bus.clock.sleep(0.2)
    assert ids_of(sim) == [(0, 9600)]


# --- the CLI ---------------------------------------------------------------------------------


def test_scan_names_the_shared_id_and_says_what_to_do() -> None:
    done = nurimc("--port", "sim://?ids=0,0", "scan", "--rates", "9600")
    assert done.code == 0, done.err
    assert "0 controller(s) found, and 1 ID(s) shared by two or more controllers" in done.out
    assert f"note: two or more controllers share ID 0 at 9600 bps: {ADVICE}" in done.err


@pytest.mark.parametrize("product", [[], ["--product", "mc"]])
def test_set_id_on_two_new_motors_says_connect_one_at_a_time(product: list[str]) -> None:
    done = nurimc("--port", "sim://?ids=0,0", *product, "--id", "0", "set", "id", "1")
    assert done.code == 1, done.err
    assert done.errors == [
        "error: two or more controllers share ID 0 at 9600 bps: connect one at a time, then give each an ID "
        "(nurimc --id 0 set id N, a different N for each); nothing was written"
    ], done.err


def test_factory_reset_cli_refuses_then_allows_with_the_option() -> None:
    refused = nurimc("--port", "sim://?ids=0,3", "--id", "3", "factory-reset", "--yes")
    assert refused.code == 1 and "--allow-shared-id" in refused.err and "nothing was sent" in refused.err
    allowed = nurimc("--port", "sim://?ids=0,3", "--id", "3", "factory-reset", "--yes", "--allow-shared-id")
    assert allowed.code == 0, allowed.err


def test_an_empty_scan_prints_the_wiring_checklist() -> None:
    done = nurimc("--port", "sim://?ids=", "scan", "--rates", "9600")
    assert done.code == 0
    assert "no controller answered" in done.err and "A to A, B to B" in done.err


@pytest.mark.parametrize(("ids", "expect", "code"), [("", 1, 1), ("1", 2, 1), ("1,2", 2, 0), ("1,2", 0, 0)])
def test_scan_expect(ids: str, expect: int, code: int) -> None:
    done = nurimc("--port", f"sim://?ids={ids}", "scan", "--rates", "9600", "--expect", str(expect))
    assert done.code == code, done.err
    if code:
        assert f"error: expected {expect} controller(s), found {len(ids.split(',')) if ids else 0}" in done.err
