"""The console across a port outage, and under a flood of many pages.

The bus is opened with reconnect (as `nurimc dashboard --port` does) on a port a proxy cuts and
restores in front of the simulator.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from starlette.testclient import TestClient

from nurimc import Bus
from nurimc.dashboard import DashboardConfig, create_app
from nurimc.dashboard import commands as c
from nurimc.dashboard.frames import FrameTap
from nurimc.dashboard.scheduler import CANCELLED, Scheduler
from nurimc.dashboard.security import SecurityPolicy, parse_listen
from nurimc.protocol import BROADCAST_ID, SetControl
from nurimc.sim.faultproxy import FaultProxy

from ..transport.outage import BAUD, cuttable_bus, frames_after_cut

LOCAL = "127.0.0.1:8485"
LATENCY = 0.01  # two TCP hops through Python threads: the answers come this much later than the wire
SAME_ORIGIN = {"origin": f"http://{LOCAL}", "host": LOCAL}


class Console:
    def __init__(self, client: TestClient, proxy: FaultProxy, sim: Any) -> None:
        self.client, self.proxy, self.sim = client, proxy, sim


@pytest.fixture
def console(tmp_path: Path) -> Iterator[Console]:
    with cuttable_bus("tcp", tmp_path, ids=(1, 2)) as (sim, proxy):
        tap = FrameTap()
        bus = Bus.open(proxy.url, BAUD, reconnect=True, tracer=tap, latency=LATENCY)
        # the proxy is a socket:// URL: reopening it from the page needs `--allow-any-port`
        policy = SecurityPolicy.build(parse_listen(LOCAL), None, any_port=True)
        config = DashboardConfig(bus, tap, policy, port=proxy.url)
        with TestClient(create_app(config), base_url=f"http://{LOCAL}") as client:
            yield Console(client, proxy, sim)
        bus.close()


def wait_for(ws: Any, test: Callable[[dict[str, Any]], bool], what: str, seconds: float = 10) -> dict[str, Any]:
    """The first message that passes `test` (ticks arrive every second, so receive never blocks long)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        message: dict[str, Any] = ws.receive_json()
        if test(message):
            return message
    raise AssertionError(f"no {what} within {seconds} s")


def ask(ws: Any, op: str, **fields: Any) -> dict[str, Any]:
    ws.send_json({"op": op, "req": op, **fields})
    return wait_for(ws, lambda m: m.get("type") == "reply" and m.get("req") == op, f"reply to {op}")


def discover(ws: Any, ids: list[int]) -> None:
    """Find the motors; asked again if one is missed (the proxy's extra hop makes answers late on a
    loaded host: discovery itself is tested elsewhere)."""
    for _ in range(3):
        found = ask(ws, "discover", rates=[BAUD])
        if [m["id"] for m in found["result"]["known"]] == ids:
            return
    raise AssertionError(f"discovery found {found}")


def test_an_estop_during_an_outage_is_latched_and_carried_out_first_on_return(console: Console) -> None:
    with console.client.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        hello = ws.receive_json()
        assert hello["port_state"]["up"] and hello["port_state"]["reconnect"]
        discover(ws, [1, 2])
        assert ask(ws, "run", id=1, rpm=30)["ok"]
        console.proxy.cut()
        lost = wait_for(ws, lambda m: m.get("type") == "port", "the port event")
        assert lost["state"] == "lost" and not lost["up"] and "lost" in lost["text"]

        refused = ask(ws, "hold", id=2)  # nothing is queued for later: refused at once with the reason
        assert not refused["ok"] and "lost" in refused["error"]
        ws.send_json({"op": "estop", "req": "stop"})
        receipt = wait_for(ws, lambda m: m.get("type") in ("estop_received", "reply"), "the receipt")
        assert receipt["type"] == "estop_received"
        reply = wait_for(ws, lambda m: m.get("type") == "reply" and m.get("req") == "stop", "the stop's reply")
        assert not reply["ok"] and reply["error"].startswith("stop pending: port lost")
        with console.client.websocket_connect("/ws", headers=SAME_ORIGIN) as other:  # a new page sees it too
            state = other.receive_json()["port_state"]
            assert state["stop_pending"] and not state["up"] and "lost" in state["message"]
        assert console.sim.controllers[0].settings.control == 0  # still driven

        console.proxy.restore()
        back = wait_for(ws, lambda m: m.get("type") == "port" and m.get("state") == "resumed", "the return")
        assert back["up"] and not back["stop_pending"]
        assert back["estop"]["latched"] and back["estop"]["control"] == {"1": "off", "2": "off"}  # read back
        assert set(back["states"]) == {"1", "2"} and all("position" in s for s in back["states"].values())
        sent = frames_after_cut(console.proxy)
        assert sent[0] == SetControl(BROADCAST_ID, 1), sent[:3]  # the stop is the first frame on the port
        assert console.sim.controllers[0].settings.control == 1
        assert wait_for(ws, lambda m: m.get("type") == "samples", "fresh samples")["rows"]


def test_a_motor_turning_by_run_is_stopped_first_when_the_port_returns(console: Console) -> None:
    with console.client.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        ws.receive_json()
        discover(ws, [1, 2])
        assert ask(ws, "run", id=2, rpm=30)["ok"]
        moved = ask(ws, "move", id=1, degrees=90, rpm=30)
        assert moved["ok"], moved  # a move ends by itself: left alone
        console.proxy.cut()
        wait_for(ws, lambda m: m.get("type") == "port", "the port event")
        console.proxy.restore()
        back = wait_for(ws, lambda m: m.get("type") == "port" and m.get("state") == "resumed", "the return")
        assert back["stopped"] == [2]
        assert frames_after_cut(console.proxy)[0] == SetControl(2, 1)
        assert console.sim.controllers[1].settings.control == 1
        assert console.sim.controllers[0].settings.control == 0


def test_nothing_asked_during_the_outage_is_sent_after_it(console: Console) -> None:
    with console.client.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        ws.receive_json()
        discover(ws, [1, 2])
        console.proxy.cut()
        wait_for(ws, lambda m: m.get("type") == "port", "the port event")
        for rpm in (10, 20, 30):
            assert not ask(ws, "run", id=2, rpm=rpm)["ok"]
        console.proxy.restore()
        wait_for(ws, lambda m: m.get("type") == "port" and m.get("state") == "resumed", "the return")
        assert not [m for m in frames_after_cut(console.proxy) if m.name == "accel_speed"]
        assert ask(ws, "read_settings", id=2)["ok"]  # and the console goes on


def test_the_page_can_reopen_the_lost_port_and_is_told_why_not_while_it_is_gone(console: Console) -> None:
    with console.client.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        ws.receive_json()
        discover(ws, [1, 2])
        console.proxy.cut()
        wait_for(ws, lambda m: m.get("type") == "port", "the port event")
        refused = ask(ws, "open_bus", port=console.proxy.url, baudrate=BAUD)
        assert not refused["ok"] and "cannot reopen" in refused["error"] and "retrying" in refused["error"]
        console.proxy.restore()
        wait_for(ws, lambda m: m.get("type") == "port" and m.get("state") == "resumed", "the return")
        assert ask(ws, "open_bus", port=console.proxy.url, baudrate=BAUD)["ok"]
        assert ask(ws, "read_settings", id=1)["ok"]


def test_the_scheduler_serves_pages_in_turn_and_the_stop_first() -> None:
    jobs = Scheduler(max_pending=50)
    answers: list[tuple[str, Any, str | None]] = []

    def done(name: str) -> Callable[[Any, str | None], None]:
        return lambda result, error: answers.append((name, result, error))

    flooder, other = object(), object()
    for _ in range(60):
        jobs.submit(c.HoldMotor(1), done("flood"), owner=flooder)
    assert jobs.pending(flooder) == 50  # bounded: the rest were refused at once
    assert sum("busy" in (e or "") for _, _, e in answers) == 10
    jobs.submit(c.ReadSettings(2), done("other"), owner=other)
    with jobs.cond:
        taken = [jobs.take(), jobs.take()]
    assert {j.owner for j in taken if j} == {flooder, other}  # the other page waited one job, not fifty
    jobs.submit(c.EmergencyStop(), done("stop"), owner=other)
    with jobs.cond:
        first = jobs.take()
    assert first is not None and isinstance(first.command, c.EmergencyStop)
    assert not [e for _, _, e in answers if e == CANCELLED]  # answered once the stop has gone out
    jobs.finish_cancelled()
    assert sum(e == CANCELLED for _, _, e in answers) == 49
    assert not jobs


def test_the_stop_is_received_first_and_wins_while_pages_flood(tmp_path: Path) -> None:
    """Counts, not timings: five pages each send 600 holds without reading; a sixth page's stop is
    the first thing it hears back, and every motor reads control off afterwards."""
    with cuttable_bus("tcp", tmp_path, ids=(1, 2)) as (sim, proxy):
        tap = FrameTap()
        bus = Bus.open(proxy.url, BAUD, reconnect=True, tracer=tap, latency=LATENCY)
        policy = SecurityPolicy.build(parse_listen(LOCAL), None)
        with TestClient(
            create_app(DashboardConfig(bus, tap, policy, port=proxy.url)), base_url=f"http://{LOCAL}"
        ) as client:
            with client.websocket_connect("/ws", headers=SAME_ORIGIN) as page:
                page.receive_json()
                discover(page, [1, 2])
                floods = [client.websocket_connect("/ws", headers=SAME_ORIGIN) for _ in range(5)]
                sockets = [f.__enter__() for f in floods]
                try:
                    for ws in sockets:
                        for n in range(600):
                            ws.send_text(json.dumps({"op": "hold", "req": n, "id": 1 + n % 2}))
                    page.send_json({"op": "estop", "req": "stop"})
                    heard = wait_for(
                        page, lambda m: m.get("type") not in ("tick", "samples", "frames", "hello"), "a reply"
                    )
                    assert heard["type"] == "estop_received"
                    reply = wait_for(page, lambda m: m.get("type") == "reply" and m.get("req") == "stop", "the stop")
                    assert reply["ok"], reply
                    assert reply["result"]["control"] == {"1": "off", "2": "off"}
                finally:
                    for f in floods:
                        f.__exit__(None, None, None)
            assert [c.settings.control for c in sim.controllers] == [1, 1]
        bus.close()
