"""The console tried from outside: the real `nurimc dashboard --sim` process, a real websocket client
on 127.0.0.1. What the in-process tests show through Starlette's TestClient, checked again through
uvicorn, the websocket protocol and TCP: the emergency stop behind hundreds of queued commands,
every malformed message answered on an open connection (an oversized one too), and no reply ever dropped."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Origin

from nurimc.dashboard.server import MESSAGE_LIMIT, TRANSPORT_LIMIT

LISTEN = ("--listen", "127.0.0.1:0")  # a free port on loopback
SIM_MOTORS = {1: 115200, 2: 115200, 3: 57600}  # nurimc.dashboard.simulated.SIM_MOTORS


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    """host:port of a fresh console process on a simulated bus, its motors discovered."""
    child = subprocess.Popen(
        [sys.executable, "-c", "from nurimc.cli.app import main; main()", *("dashboard", "--sim"), *LISTEN],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        assert child.stdout is not None
        line = child.stdout.readline()
        match = re.search(r"ready: http://(\S+)/", line)
        assert match, f"the console did not start: {line}{child.stdout.read() if child.poll() is not None else ''}"
        host = match.group(1)
        with open_socket(host) as ws:
            found = ask(ws, "discover", rates=sorted(set(SIM_MOTORS.values())))
            assert found["ok"], found
        yield host
        assert child.poll() is None, "the console stayed up through every test"
    finally:
        child.terminate()
        child.wait(timeout=60)


def open_socket(host: str, *, compress: bool = True) -> ClientConnection:
    """A client as a browser is: permessage-deflate offered (and taken by the server) unless compress=False."""
    return connect(
        f"ws://{host}/ws",
        origin=Origin(f"http://{host}"),
        max_queue=None,
        max_size=None,
        compression="deflate" if compress else None,
    )


def replies(ws: ClientConnection, count: int, timeout: float = 30.0) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    deadline = time.monotonic() + timeout
    while len(out) < count:
        message = json.loads(ws.recv(timeout=max(0.1, deadline - time.monotonic())))
        if message.get("type") == "reply":
            out.append(message)
    return out


def ask(ws: ClientConnection, op: str, **fields: Any) -> dict[str, Any]:
    ws.send(json.dumps({"op": op, "req": op, **fields}))
    while True:
        message = json.loads(ws.recv(timeout=30))
        if message.get("type") == "reply" and message.get("req") == op:
            return message  # type: ignore[no-any-return]


def controls(ws: ClientConnection) -> dict[int, Any]:
    return {i: ask(ws, "read_settings", id=i)["result"]["settings"]["control"] for i in SIM_MOTORS}


@pytest.mark.parametrize(("queued", "count"), [("hold", 500), ("move", 300)])
def test_estop_behind_queued_commands_leaves_every_motor_with_control_off(server: str, queued: str, count: int) -> None:
    with open_socket(server) as ws:
        assert ask(ws, "watch", ids=list(SIM_MOTORS))["ok"]
        for n in range(count):
            extra = {"degrees": (n % 20) * 5 - 50, "rpm": 120} if queued == "move" else {}
            ws.send(json.dumps({"op": queued, "req": n, "id": 1 + n % 3, **extra}))
        ws.send(json.dumps({"op": "estop", "req": "stop"}))
        got = replies(ws, count + 1)
        assert sorted(str(r["req"]) for r in got) == sorted([*map(str, range(count)), "stop"]), "one reply each"
        stop = next(r for r in got if r["req"] == "stop")
        assert stop["ok"], stop
        assert stop["result"]["rates"] == [57600, 115200], "control off was broadcast at every known rate"
        assert stop["result"]["control"] == {"1": "off", "2": "off", "3": "off"}, stop
        after = got[got.index(stop) + 1 :]
        assert all(not r["ok"] for r in after), "nothing sent before the stop ran after it"
        time.sleep(0.3)  # anything that slipped through would show by now
        assert controls(ws) == {1: "off", 2: "off", 3: "off"}


BAD: list[str | bytes] = [
    b"\x00\x01\x02binary",
    "{not json",
    "[" * 5000 + "]" * 5000,
    '{"op":"move","id":1,"degrees":"inf","rpm":60}',
    '{"op":"move","id":1,"degrees":Infinity,"rpm":60}',
    '{"op":"move","id":1,"degrees":1e308,"rpm":60}',
    '{"op":"move","id":1,"degrees":1e400,"rpm":60}',
    '{"op":"run","id":1,"rpm":30,"ramp":1e300}',
    '{"op":"restore","document":{"format":"nurimc-backup/1","motors":[{"id":1,"settings":{"ratio":"inf"}}]}}',
    '{"op":"move","id":"1","degrees":10,"rpm":60}',
    '{"op":"move","id":1,"degrees":[10],"rpm":60}',
    '{"op":"move","id":1,"degrees":10,"rpm":-60}',
    '{"op":"set","id":1,"name":"position-kp","value":true}',
    '{"op":"watch","ids":"1,2"}',
    '{"op":"step","id":1,"amplitude":10,"duration":1e400}',
    "[]",
    '{"op":null}',
]


def test_every_malformed_message_gets_an_error_reply_on_an_open_connection(server: str) -> None:
    with open_socket(server) as ws:
        for message in BAD:
            ws.send(message)
            (reply,) = replies(ws, 1)
            shown = message[:60]
            assert reply["ok"] is False and reply["error"], shown
            assert "internal error" not in reply["error"], (shown, reply["error"])
        assert ask(ws, "read_settings", id=1)["ok"], "the same connection still works"


MIB = 1 << 20
OVERSIZED: list[tuple[str | bytes, int]] = [  # (message, its size in bytes as sent)
    ('{"op":"read_settings","id":1,"pad":"' + "x" * (2 * MIB) + '"}', 2 * MIB + 38),
    (bytes(range(256)) * (2 * MIB // 256), 2 * MIB),
    ("é" * (MIB // 2 + 1), MIB + 2),  # 524,289 characters, 1,048,578 bytes in UTF-8
    (b"\x00" * (TRANSPORT_LIMIT - MIB), TRANSPORT_LIMIT - MIB),  # 15 MiB: still an error reply
]


@pytest.mark.parametrize(
    ("message", "size"), OVERSIZED, ids=["2MiB-text", "2MiB-binary", "1MiB+2-utf8", "15MiB-binary"]
)
def test_a_message_over_1_mib_gets_an_error_reply_and_the_connection_stays_open(
    server: str, message: str | bytes, size: int
) -> None:
    with open_socket(server) as ws:
        for _ in range(2):  # twice on one connection: the first did not leave it half-read
            ws.send(message)
            (reply,) = replies(ws, 1)
            assert reply == {
                "type": "reply",
                "req": None,
                "ok": False,
                "result": None,
                "error": f"message of {size} bytes is over the 1 MiB limit",
            }
        answered = ask(ws, "read_settings", id=1)
        assert answered["ok"], answered
        assert answered["result"]["settings"]["control"] in ("on", "off")


def test_an_oversized_message_in_fragments_uncompressed_gets_an_error_reply(server: str) -> None:
    """64 KiB frames on the wire as they are: the size counted over the fragments, not per frame."""
    piece = bytes(range(256)) * 256
    with open_socket(server, compress=False) as ws:
        ws.send([piece] * 32)
        (reply,) = replies(ws, 1)
        assert reply["error"] == f"message of {32 * len(piece)} bytes is over the 1 MiB limit"
        ws.send(["x" * (MIB // 2), "y" * (MIB // 2), "z"])
        (reply,) = replies(ws, 1)
        assert reply["error"] == f"message of {MIB + 1} bytes is over the 1 MiB limit"
        assert ask(ws, "read_settings", id=1)["ok"]


def test_a_message_of_exactly_1_mib_is_read(server: str) -> None:
    head, tail = '{"op":"watch","req":"edge","ids":[1],"pad":"', '"}'
    message = head + "x" * (MESSAGE_LIMIT - len(head) - len(tail)) + tail
    assert len(message.encode()) == MESSAGE_LIMIT
    with open_socket(server) as ws:
        ws.send(message)
        (reply,) = replies(ws, 1)
        assert reply["req"] == "edge", "read and decoded: the request number came back"
        assert "limit" not in (reply["error"] or ""), reply


def test_a_deflated_message_over_the_16_mib_hard_cap_closes_the_connection_with_1009(server: str) -> None:
    """16 MiB + 1 zero bytes, a few kilobytes on the wire: the cap counts the message decompressed."""
    with open_socket(server) as ws:
        with pytest.raises(ConnectionClosed):
            ws.send(b"\x00" * (TRANSPORT_LIMIT + 1))
            while True:
                ws.recv(timeout=30)
        assert ws.protocol.close_rcvd is not None and ws.protocol.close_rcvd.code == 1009, ws.protocol.close_rcvd
    with open_socket(server) as again:
        assert ask(again, "read_settings", id=1)["ok"], "the server itself is unharmed"


@pytest.mark.parametrize("fragmented", [False, True], ids=["one-frame", "after-250-fragments-of-64KiB"])
def test_a_frame_header_over_the_hard_cap_is_refused_before_its_payload(server: str, fragmented: bool) -> None:
    """Only the header of the frame that would cross 16 MiB is sent, never its payload: the server
    closes with 1009 all the same, so it did not wait to buffer the payload. (A client that does
    send the payload may see the connection reset instead: the server closes with it unread.)"""
    with RawWebSocket(server) as raw:
        if fragmented:
            piece = b"\x00" * (1 << 16)
            raw.send_frame(0x2, False, len(piece))
            raw.sock.sendall(piece)
            for _ in range(249):
                raw.send_frame(0x0, False, len(piece))
                raw.sock.sendall(piece)
            raw.send_frame(0x0, True, TRANSPORT_LIMIT - 250 * len(piece) + 1)  # one byte too many, in all
        else:
            raw.send_frame(0x2, True, TRANSPORT_LIMIT + 1)
        assert raw.close_code() == 1009
    with open_socket(server) as again:
        assert ask(again, "read_settings", id=1)["ok"], "the server itself is unharmed"


class RawWebSocket:
    """A websocket client by hand, to send a frame's header without its payload."""

    def __init__(self, host: str) -> None:
        name, port = host.rsplit(":", 1)
        self.sock = socket.create_connection((name, int(port)), timeout=30)
        self.sock.sendall(
            f"GET /ws HTTP/1.1\r\nHost: {host}\r\nOrigin: http://{host}\r\nUpgrade: websocket\r\n"
            "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
            "Sec-WebSocket-Version: 13\r\n\r\n".encode()
        )
        self.buffer = bytearray()
        self._need_until(b"\r\n\r\n")
        head, _, rest = bytes(self.buffer).partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 101"), head
        self.buffer = bytearray(rest)

    def __enter__(self) -> RawWebSocket:
        return self

    def __exit__(self, *_: object) -> None:
        self.sock.close()

    def send_frame(self, opcode: int, fin: bool, length: int) -> None:
        """The header of one masked client frame (mask 0: the payload goes as it is)."""
        first = bytes([(0x80 if fin else 0) | opcode])
        if length < 126:
            size = bytes([0x80 | length])
        elif length < 1 << 16:
            size = bytes([0x80 | 126]) + length.to_bytes(2, "big")
        else:
            size = bytes([0x80 | 127]) + length.to_bytes(8, "big")
        self.sock.sendall(first + size + b"\x00" * 4)

    def close_code(self) -> int:
        """Skip the server's messages up to its close frame; the code in it."""
        while True:
            self._need(2)
            opcode, length, offset = self.buffer[0] & 0x0F, self.buffer[1] & 0x7F, 2
            if length >= 126:
                offset = 4 if length == 126 else 10
                self._need(offset)
                length = int.from_bytes(self.buffer[2:offset], "big")
            self._need(offset + length)
            payload = bytes(self.buffer[offset : offset + length])
            del self.buffer[: offset + length]
            if opcode == 0x8:
                return int.from_bytes(payload[:2], "big")

    def _need(self, count: int) -> None:
        while len(self.buffer) < count:
            self._read()

    def _need_until(self, marker: bytes) -> None:
        while marker not in self.buffer:
            self._read()

    def _read(self) -> None:
        chunk = self.sock.recv(1 << 16)
        if not chunk:
            raise EOFError("the server closed the connection without a close frame")
        self.buffer.extend(chunk)


def test_3000_requests_get_3000_replies_each_done_or_busy(server: str) -> None:
    total = 3000
    with open_socket(server) as ws:
        for n in range(total):
            ws.send(json.dumps({"op": "read_settings", "req": n, "id": 1 + n % 3}))
        got = replies(ws, total, timeout=60)
        assert sorted(r["req"] for r in got) == list(range(total)), "every request answered exactly once"
        refused = [r for r in got if not r["ok"]]
        assert all(re.match(r"busy: .* try again", r["error"]) for r in refused), {r["error"] for r in refused}
        assert total - len(refused) >= 256, "the first page-full were carried out"


def test_hello_heartbeat_and_stop_receipt(server: str) -> None:
    """What lets a page notice a hung or restarted server: its boot and clock, a tick every second,
    and a receipt for the stop ahead of everything else waiting for that page."""
    with open_socket(server) as ws:
        hello = json.loads(ws.recv(timeout=30))
        assert hello["type"] == "hello" and len(hello["boot"]) == 16 and hello["clock"] > 0
        began = time.monotonic()
        while json.loads(ws.recv(timeout=30))["type"] != "tick":
            pass
        assert time.monotonic() - began < 5, "ticks keep coming (every second)"
        for n in range(200):
            ws.send(json.dumps({"op": "hold", "req": n, "id": 1 + n % 3}))
        ws.send(json.dumps({"op": "estop", "req": "stop"}))
        seen: list[tuple[str, Any]] = []
        while ("reply", "stop") not in seen:
            message = json.loads(ws.recv(timeout=30))
            seen.append((message["type"], message.get("req")))
        assert ("estop_received", "stop") in seen
        assert seen.index(("estop_received", "stop")) < seen.index(("reply", "stop"))
    with open_socket(server) as again:
        assert json.loads(again.recv(timeout=30))["boot"] == hello["boot"], "the same process, the same boot"
