"""The console under abuse: every bad message answered on an open connection, no reply dropped,
and an emergency stop that wins over everything queued before it."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest
from starlette.testclient import TestClient

from nurimc.dashboard import DashboardConfig, create_app
from nurimc.dashboard import commands as c
from nurimc.dashboard.frames import FrameTap
from nurimc.dashboard.security import SecurityPolicy, parse_listen
from nurimc.dashboard.server import MESSAGE_LIMIT, TRANSPORT_LIMIT, uvicorn_options
from nurimc.dashboard.simulated import simulated_bus
from nurimc.dashboard.worker import MAX_PENDING

LOCAL = "127.0.0.1:8485"
SAME_ORIGIN = {"origin": f"http://{LOCAL}", "host": LOCAL}
MOTORS = {1: 115200, 2: 57600}


@pytest.fixture(scope="module")
def console() -> Iterator[TestClient]:
    tap = FrameTap()
    sim, bus = simulated_bus(tap, MOTORS)
    policy = SecurityPolicy.build(parse_listen(LOCAL), None)
    with TestClient(create_app(DashboardConfig(bus, tap, policy, sim=True)), base_url=f"http://{LOCAL}") as client:
        with client.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
            assert ask(ws, "discover", rates=[115200, 57600])["ok"]
        yield client
    bus.close()
    sim.close()


def replies(ws: Any, count: int) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    while len(out) < count:
        message = ws.receive_json()
        if message.get("type") == "reply":
            out.append(message)
    return out


def ask(ws: Any, op: str, **fields: Any) -> dict[str, Any]:
    ws.send_json({"op": op, "req": op, **fields})
    while True:
        message = ws.receive_json()
        if message.get("type") == "reply" and message.get("req") == op:
            return message  # type: ignore[no-any-return]


def controls(ws: Any) -> dict[int, Any]:
    return {i: ask(ws, "read_settings", id=i)["result"]["settings"]["control"] for i in MOTORS}


BAD_TEXT = [
    "{not json",
    "[" * 5000 + "]" * 5000,
    '{"op": "move", "req": 1, "id": 1, "degrees": {"a": ' * 40 + "1" + "}" * 40 + ', "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": Infinity, "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": NaN, "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": 1e400, "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": 1e308, "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": "inf", "rpm": 60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": 10, "rpm": -60}',
    '{"op": "move", "req": 1, "id": 1, "degrees": 10, "rpm": "60"}',
    '{"op": "move", "req": 1, "id": 1e400, "degrees": 10, "rpm": 60}',
    '{"op": "run", "req": 1, "id": 1, "rpm": 30, "ramp": 1e300}',
    '{"op": "run", "req": 1, "id": 1, "rpm": 1' + "0" * 5000 + "}",
    '{"op": "set", "req": 1, "id": 1, "name": "ratio", "value": "inf"}',
    '{"op": "set", "req": 1, "id": 1, "name": "ratio", "value": 1e308}',
    '{"op": "set", "req": 1, "id": 1, "name": "position-kp", "value": "77"}',
    '{"op": "set", "req": 1, "id": 1, "name": ["ratio"], "value": 1}',
    '{"op": "restore", "req": 1, "document": {"format": "nurimc-backup/1", '
    '"motors": [{"id": 1, "settings": {"ratio": "inf"}}]}}',
    '{"op": "restore", "req": 1, "document": {"format": "nurimc-backup/1", '
    '"motors": [{"id": 1, "settings": {"position-kp": 1e400}}]}}',
    '{"op": "discover", "req": 1, "rates": [{"a": 1}]}',
    '{"op": "change_baud", "req": 1, "id": 1, "baudrate": [1]}',
    '{"op": "factory_reset", "req": 1, "id": 1, "confirm": "yes"}',
    '{"op": "hold", "req": 1, "id": 1, "gen": "x"}',
    '"just a string"',
    "null",
    '{"op": {"x": 1}}',
]


def test_every_bad_message_gets_an_error_reply_and_the_connection_stays_open(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        ws.send_bytes(b"\x00\x01binary")
        (reply,) = replies(ws, 1)
        assert reply["ok"] is False and "binary" in reply["error"]
        for text in BAD_TEXT:
            ws.send_text(text)
            (reply,) = replies(ws, 1)
            assert reply["ok"] is False and reply["error"], text[:80]
            assert "internal error" not in reply["error"], (text[:80], reply["error"])
        assert ask(ws, "watch", ids=[1, 2])["ok"], "the same connection still works"


@pytest.mark.parametrize("kind", ["text", "bytes"])
def test_a_message_over_1_mib_is_answered_not_read(console: TestClient, kind: str) -> None:
    size = MESSAGE_LIMIT + 1
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        if kind == "text":  # valid JSON a byte too long: refused by its size, not parsed
            head = '{"op": "watch", "req": "big", "ids": [1], "pad": "'
            ws.send_text(head + "x" * (size - len(head) - 2) + '"}')
        else:
            ws.send_bytes(b"{" * size)
        (reply,) = replies(ws, 1)
        assert reply["req"] is None and reply["ok"] is False
        assert reply["error"] == f"message of {size} bytes is over the 1 MiB limit"
        assert ask(ws, "watch", ids=[1, 2])["ok"], "the same connection still works"


def test_the_transport_assembles_up_to_the_hard_cap_and_pauses_between_messages() -> None:
    from uvicorn.config import WS_PROTOCOLS

    options = uvicorn_options()
    assert options["ws_max_size"] == TRANSPORT_LIMIT == 16 * MESSAGE_LIMIT
    assert options["ws_max_queue"] == 1, "the legacy implementation (old uvicorn) queues one message at most"
    sansio = "websockets-sansio" in WS_PROTOCOLS
    assert options["ws"] == ("websockets-sansio" if sansio else "websockets")


def test_negative_rpm_and_blank_values_are_refused_with_a_reason() -> None:
    for message, says in [
        ({"op": "move", "id": 1, "degrees": 10, "rpm": -60}, "rpm must be above 0"),
        ({"op": "move", "id": 1, "degrees": None, "rpm": 60}, "missing 'degrees'"),
        ({"op": "move", "id": 1, "degrees": "", "rpm": 60}, "degrees must be a number"),
        ({"op": "run", "id": 1, "rpm": 30, "ramp": 1e300}, "ramp must be a number (finite, in range)"),
        ({"op": "factory_reset", "id": 3, "confirm": "RESET 4"}, "confirm by typing 'RESET 3'"),
        ({"op": "change_id", "id": 3, "new_id": 3}, "already has that ID"),
        ({"op": "change_id", "id": 3, "new_id": 255}, "0..254"),
    ]:
        with pytest.raises(c.CommandError) as refused:
            c.parse(message)
        assert says in str(refused.value)
    assert c.parse({"op": "factory_reset", "id": 3, "confirm": "RESET 3"}) == c.FactoryResetMotor(3)


def test_no_reply_is_dropped_under_a_flood(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        total = 3000
        for n in range(total):
            ws.send_text(json.dumps({"op": "read_settings", "req": n, "id": 1}))
        got = replies(ws, total)
        assert sorted(r["req"] for r in got) == list(range(total))
        busy = [r for r in got if not r["ok"]]
        assert all("busy" in r["error"] and "try again" in r["error"] for r in busy)
        assert len(busy) >= total - MAX_PENDING - 200, "the page is told to try again, not left waiting"


@pytest.mark.parametrize("queued", ["hold", "move"])
def test_emergency_stop_wins_over_everything_queued_before_it(console: TestClient, queued: str) -> None:
    count = 500 if queued == "hold" else 300
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        for n in range(count):
            device_id = 1 + n % 2
            extra = {"degrees": (n % 20) * 5, "rpm": 60} if queued == "move" else {}
            ws.send_text(json.dumps({"op": queued, "req": n, "id": device_id, **extra}))
        ws.send_text(json.dumps({"op": "estop", "req": "stop"}))
        got = replies(ws, count + 1)
        stop = next(r for r in got if r["req"] == "stop")
        assert stop["ok"], stop
        assert set(stop["result"]["control"].values()) == {"off"}, stop
        order = [r["req"] for r in got]
        after = order[order.index("stop") + 1 :]
        assert all(next(r for r in got if r["req"] == n)["ok"] is False for n in after), (
            "nothing sent before the stop was carried out after it"
        )
        assert controls(ws) == {1: "off", 2: "off"}


def test_a_command_from_before_a_stop_is_refused_and_a_new_one_works(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        hello = ws.receive_json()
        assert hello["type"] == "hello"
        stop = ask(ws, "estop")
        generation = stop["result"]["generation"]
        assert generation > hello["generation"]
        old = ask(ws, "hold", id=1, gen=hello["generation"])
        assert not old["ok"] and "before emergency stop" in old["error"]
        assert controls(ws)[1] == "off"
        held = ask(ws, "hold", id=1, gen=generation)
        assert held["ok"], held["error"]
        assert controls(ws)[1] == "on"
        assert ask(ws, "release", id=1)["ok"]


def test_a_new_page_is_told_the_known_motors_at_once(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        hello = ws.receive_json()
    assert hello["type"] == "hello"
    assert [(m["id"], m["baudrate"]) for m in hello["motors"]] == [(1, 115200), (2, 57600)]
    assert all(m["firmware"] is not None for m in hello["motors"])
    assert console.get("/api/info").json()["motors"] == hello["motors"]


def test_set_zero_makes_the_current_position_zero(console: TestClient) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        assert ask(ws, "move", id=1, degrees=30, rpm=600)["ok"]
        zeroed = ask(ws, "set_zero", id=1)
        assert zeroed["ok"], zeroed
        assert abs(zeroed["result"]["device_position"]) < 1.0
        assert ask(ws, "release", id=1)["ok"]


UNREADABLE = [
    ("move", "degrees", '{"op": "move", "req": 7, "id": 1, "degrees": NaN, "rpm": 60}'),
    ("move", "degrees", '{"op": "move", "req": 7, "id": 1, "degrees": -Infinity, "rpm": 60}'),
    ("move", "degrees", '{"op": "move", "req": 7, "id": 1, "degrees": ' + "9" * 5000 + ', "rpm": 60}'),
    ("run", "rpm", '{"op": "run", "req": 7, "id": 1, "rpm": Infinity}'),
    ("move", "id", '{"op": "move", "req": 7, "id": ' + "1" * 4400 + ', "degrees": 1, "rpm": 60}'),
    ("set", "ratio", '{"op": "set", "req": 7, "id": 1, "name": "ratio", "value": NaN}'),
    ("restore", "position-kp", '{"op": "restore", "req": 7, "document": {"format": "nurimc-backup/1", '
     '"motors": [{"id": 1, "settings": {"position-kp": Infinity}}]}}'),
]  # fmt: skip


@pytest.mark.parametrize(("op", "field", "text"), UNREADABLE)
def test_an_unreadable_number_is_answered_with_its_request_and_field(
    console: TestClient, op: str, field: str, text: str
) -> None:
    # NaN, Infinity and integers past 4,300 digits are not JSON numbers the console reads; the
    # request is still answered as itself (its req) and the error names the field
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        ws.send_text(text)
        (reply,) = replies(ws, 1)
        assert reply["ok"] is False and reply["req"] == 7, reply
        assert field in reply["error"] and "internal error" not in reply["error"], reply["error"]
        assert len(reply["error"]) < 300 and "\n" not in reply["error"]
