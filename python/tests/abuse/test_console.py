"""The console's HTTP and websocket endpoints under malformed and slow clients (issue 39,
item 8): the real app under uvicorn with the connection limits, on loopback. Whatever a client
sends, the server answers it (4xx) or closes it, and goes on serving: a new page's request and
an open page's emergency stop are answered after each."""

from __future__ import annotations

import base64
import contextlib
import json
import os
import socket
import threading
import time
from collections.abc import Iterator

import pytest
import uvicorn
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Origin

from nurimc.dashboard import DashboardConfig, create_app
from nurimc.dashboard.connlimits import ConnectionLimits, server_options
from nurimc.dashboard.frames import FrameTap
from nurimc.dashboard.security import SecurityPolicy, parse_listen
from nurimc.dashboard.server import uvicorn_options
from nurimc.dashboard.simulated import simulated_bus

FAST = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


class Console:
    def __init__(self) -> None:
        self.tap = FrameTap()
        self.sim, self.bus = simulated_bus(self.tap, {1: 115200})
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(256)
        self.port = self.sock.getsockname()[1]
        self.host = f"127.0.0.1:{self.port}"
        policy = SecurityPolicy.build(parse_listen(self.host), None)
        app = create_app(DashboardConfig(self.bus, self.tap, policy, sim=True, port="sim://"))
        self.limits = ConnectionLimits(per_address=64, total=96, header_timeout=1.0)
        options = {**uvicorn_options(), **server_options(self.limits)}
        self.server = uvicorn.Server(uvicorn.Config(app, log_level="critical", **options))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 30
        while not self.server.started:
            assert time.monotonic() < deadline and self.thread.is_alive(), "the console did not start"
            time.sleep(0.01)

    @contextlib.contextmanager
    def page(self) -> Iterator[ClientConnection]:
        with connect(f"ws://{self.host}/ws", origin=Origin(f"http://{self.host}"), open_timeout=20) as ws:
            assert json.loads(ws.recv(timeout=20))["type"] == "hello"
            yield ws

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(15)
        self.bus.close()
        self.sim.close()


@pytest.fixture(scope="module")
def console() -> Iterator[Console]:
    c = Console()
    yield c
    c.close()


def raw(console: Console, data: bytes, timeout: float = 10.0) -> bytes:
    """Send `data`, read what comes back until the server closes (or the timeout)."""
    with socket.create_connection(("127.0.0.1", console.port), timeout=timeout) as conn:
        try:
            conn.sendall(data)
            conn.shutdown(socket.SHUT_WR)
        except OSError:
            pass
        answer = b""
        try:
            while chunk := conn.recv(65536):
                answer += chunk
        except (TimeoutError, ConnectionResetError):
            pass
        return answer


def still_serving(console: Console) -> None:
    answer = raw(console, f"GET /api/info HTTP/1.1\r\nHost: {console.host}\r\nConnection: close\r\n\r\n".encode())
    assert answer.startswith(b"HTTP/1.1 200"), answer[:200]


def estop(ws: ClientConnection) -> float:
    began = time.monotonic()
    ws.send(json.dumps({"op": "estop", "req": "stop"}))
    while True:
        message = json.loads(ws.recv(timeout=20))
        if message.get("type") == "reply" and message.get("req") == "stop":
            assert message["ok"], message
            return time.monotonic() - began


TOKENS = st.sampled_from(
    [b"GET", b"POST", b"\x00", b" ", b"/", b"/ws", b"/api/info", b"HTTP/1.1", b"HTTP/9.9", b"\r\n", b"\n", b":",
     b"Host", b"Host: 127.0.0.1", b"Upgrade: websocket", b"Connection: Upgrade", b"Content-Length: ", b"-1",
     b"99999999999999999999", b"Transfer-Encoding: chunked", b"Sec-WebSocket-Key: ", b"Sec-WebSocket-Version: 13",
     b"Origin: http://evil.example", b"\xff\xfe", b"%00", b"?token=", b"..", b"a" * 300]
)  # fmt: skip


@FAST
@given(parts=st.lists(TOKENS, max_size=40), tail=st.binary(max_size=64))
def test_malformed_requests_get_4xx_or_a_close(console: Console, parts: list[bytes], tail: bytes) -> None:
    answer = raw(console, b"".join(parts) + tail)
    if answer:
        status = answer.split(b"\r\n", 1)[0]
        assert status.startswith(b"HTTP/1.1 "), status
        code = int(status.split()[1])
        assert code < 500 or (code == 503 and b"uPlot" in answer), answer[:300]  # 503: the plot library not installed
    still_serving(console)


def test_a_slow_client_is_closed_and_the_page_goes_on(console: Console) -> None:
    with console.page() as ws:
        slow = socket.create_connection(("127.0.0.1", console.port), timeout=20)
        try:
            began = time.monotonic()
            closed = False
            for byte in b"GET /api/info HTTP/1.1\r\nHost: 127.0.0.1\r\n":  # one byte every 0.2 s: slowloris
                try:
                    slow.sendall(bytes((byte,)))
                except OSError:
                    closed = True
                    break
                time.sleep(0.2)
                if time.monotonic() - began > 6:
                    break
            if not closed:
                slow.settimeout(10)
                try:
                    closed = slow.recv(1) == b""
                except (ConnectionResetError, TimeoutError):
                    closed = True
            assert closed, "a client sending its headers a byte at a time is closed"
            assert time.monotonic() - began < 15
            assert estop(ws) < 5
        finally:
            slow.close()
    still_serving(console)


def test_garbage_websocket_frames_close_that_socket_only(console: Console) -> None:
    with console.page() as ws:
        key = base64.b64encode(os.urandom(16)).decode()
        handshake = (
            f"GET /ws HTTP/1.1\r\nHost: {console.host}\r\nOrigin: http://{console.host}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        ).encode()
        for garbage in (os.urandom(200), b"\x81\x7f" + b"\xff" * 8, b"\x88\x00", b"\x01\x05hello" * 50):
            answer = raw(console, handshake + garbage)
            assert answer.startswith(b"HTTP/1.1 101"), answer[:200]
        assert estop(ws) < 5
    still_serving(console)


def test_half_open_connections_over_the_caps_leave_the_page_working(console: Console) -> None:
    with console.page() as ws:
        held = []
        try:
            for _ in range(300):  # over both caps (64 per address, 96 in all)
                conn = socket.create_connection(("127.0.0.1", console.port), timeout=10)
                conn.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n")
                held.append(conn)
            assert estop(ws) < 5
            still_serving(console)
            with console.page() as fresh:
                assert estop(fresh) < 5
        finally:
            for conn in held:
                conn.close()
