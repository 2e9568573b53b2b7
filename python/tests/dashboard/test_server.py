"""The console's server side: who may connect, and what a page may ask (same checks as the library)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from starlette.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from nurimc.dashboard import DashboardConfig, create_app
from nurimc.dashboard import commands as c
from nurimc.dashboard.frames import FrameTap
from nurimc.dashboard.security import ListenError, SecurityPolicy, parse_listen
from nurimc.dashboard.simulated import simulated_bus

LOCAL = "127.0.0.1:8485"
TOKEN = "a-long-enough-secret-token"
SAME_ORIGIN = {"origin": f"http://{LOCAL}", "host": LOCAL}


@pytest.fixture(scope="module")
def console() -> Iterator[TestClient]:
    tap = FrameTap()
    sim, bus = simulated_bus(tap, {1: 115200, 2: 115200})
    policy = SecurityPolicy.build(parse_listen(LOCAL), None)
    with TestClient(create_app(DashboardConfig(bus, tap, policy, sim=True)), base_url=f"http://{LOCAL}") as client:
        yield client
    bus.close()
    sim.close()


def ask(ws, op: str, **fields) -> dict:  # type: ignore[no-untyped-def]
    ws.send_json({"op": op, "req": op, **fields})
    while True:
        message = ws.receive_json()
        if message.get("type") == "reply" and message.get("req") == op:
            return message  # type: ignore[no-any-return]


def test_page_and_catalogue_are_served(console: TestClient) -> None:
    assert "nurimc console" in console.get("/").text
    info = console.get("/api/info").json()
    assert info["sim"] is True and {s["name"] for s in info["settings"]} >= {"position-kp", "ratio"}


def test_missing_plot_library_is_explained(console: TestClient, monkeypatch: pytest.MonkeyPatch) -> None:
    from nurimc.dashboard import server

    monkeypatch.setattr(server, "UPLOT", "vendor/missing.js")
    response = console.get("/")
    assert response.status_code == 503 and "dashboard-assets" in response.text


def test_foreign_host_is_refused(console: TestClient) -> None:  # DNS rebinding
    response = console.get("/", headers={"host": "evil.example:8485"})
    assert response.status_code == 421


def test_cross_origin_websocket_is_refused(console: TestClient) -> None:
    foreign = {"origin": "http://evil.example", "host": LOCAL}
    with pytest.raises(WebSocketDisconnect) as refused, console.websocket_connect("/ws", headers=foreign) as ws:
        ws.receive_text()
    assert refused.value.code == 1008


def test_commands_are_validated_like_the_library(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        bad = ask(ws, "set", id=1, name="ratio", value=0)
        assert not bad["ok"] and "0.1..6553.3" in bad["error"]
        assert not ask(ws, "warp_drive")["ok"]
        assert not ask(ws, "move", id=300, degrees=10, rpm=10)["ok"]
        too_far = ask(ws, "move", id=1, degrees=700, rpm=10)
        assert not too_far["ok"] and "655.33" in too_far["error"]
        assert not ask(ws, "run", id=1, rpm=0)["ok"]


def test_setting_round_trip_and_emergency_stop(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        found = ask(ws, "discover", rates=[115200])
        assert found["ok"], found
        written = ask(ws, "set", id=2, name="position-kp", value=77)
        assert written["ok"] and written["result"]["value"] == 77
        stopped = ask(ws, "estop")
        assert stopped["ok"] and set(stopped["result"]["control"].values()) == {"off"}


def test_listen_rules() -> None:
    with pytest.raises(ListenError, match="--token"):
        SecurityPolicy.build(parse_listen("0.0.0.0:8485"), None)
    with pytest.raises(ListenError, match="16 characters"):
        SecurityPolicy.build(parse_listen("0.0.0.0:8485"), "short")
    policy = SecurityPolicy.build(parse_listen("0.0.0.0:8485"), TOKEN)
    assert policy.token_ok(TOKEN) and not policy.token_ok("wrong") and not policy.token_ok(None)
    with pytest.raises(ListenError):
        parse_listen("nonsense")


def test_token_is_required_off_loopback() -> None:
    tap = FrameTap()
    sim, bus = simulated_bus(tap, {1: 115200})
    policy = SecurityPolicy.build(parse_listen("0.0.0.0:8485"), TOKEN)
    with TestClient(create_app(DashboardConfig(bus, tap, policy, sim=True)), base_url="http://10.9.8.7:8485") as client:
        assert client.get("/").status_code == 401
        assert client.get(f"/?token={TOKEN}", follow_redirects=False).status_code == 303
        client.cookies.set("nurimc_token", TOKEN)
        assert client.get("/").status_code == 200
    bus.close()
    sim.close()


def test_parse_refuses_garbage() -> None:
    for message in ({}, {"op": 3}, {"op": "set", "id": 1, "name": "colour", "value": 1}, {"op": "step", "id": 1}):
        with pytest.raises(c.CommandError):
            c.parse(message)
