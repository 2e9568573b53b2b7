"""The console as an attack surface (issue 39, item 5): what the page may open, the security
headers, and the connection limits under half-open and idle floods (uvicorn on loopback)."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import uvicorn
from starlette.testclient import TestClient

from nurimc.dashboard import DashboardConfig, create_app
from nurimc.dashboard.connlimits import ConnectionLimits, server_options
from nurimc.dashboard.frames import FrameTap
from nurimc.dashboard.security import SecurityPolicy, parse_listen, port_refusal
from nurimc.dashboard.simulated import simulated_bus

LOCAL = "127.0.0.1:8485"
SAME_ORIGIN = {"origin": f"http://{LOCAL}", "host": LOCAL}


@pytest.mark.parametrize("url", ["/dev/ttyUSB0", "/dev/serial/by-id/usb-FTDI-if00", "COM3", "sim://", "sim://?ids=1,2"])
def test_serial_devices_and_the_plain_simulator_may_be_opened(url: str) -> None:
    assert port_refusal(url) is None


@pytest.mark.parametrize(
    ("url", "reason"),
    [
        ("spy:///dev/ttyUSB0?file=/home/me/.bashrc", "spy://"),
        ("socket://10.0.0.5:22", "socket://"),
        ("rfc2217://host:2217", "rfc2217://"),
        ("loop://", "loop://"),
        ("hwgrep://.*", "hwgrep://"),
        ("sim://?state=/tmp/x", "option state"),
        ("SIM://?ids=1&State=/tmp/x", "option State"),
        ("/etc/passwd", "not a serial device"),
        ("/dev/../etc/passwd", "not a serial device"),
        ("relative/path", "not a serial device"),
        ("/dev/ttyUSB0\nspy://x", "control characters"),
    ],
)
def test_files_and_network_are_refused_with_a_reason(url: str, reason: str) -> None:
    refusal = port_refusal(url)
    assert refusal is not None and reason in refusal and "\n" not in refusal
    if "://" in url and "control" not in reason:
        assert "--allow-any-port" in refusal


def test_a_link_to_a_terminal_may_be_opened_a_link_to_a_file_may_not(tmp_path: Path) -> None:
    """`nurimc sim --link /tmp/nurimc0` (the README's quick start) or a udev alias: a name that
    resolves to a serial terminal under /dev is a serial device; a link to anything else is not."""
    master, slave = os.openpty()
    try:
        terminal = tmp_path / "nurimc0"
        terminal.symlink_to(os.ttyname(slave))
        assert port_refusal(str(terminal)) is None
        secret = tmp_path / "secret"
        secret.write_text("x")
        to_file = tmp_path / "to-file"
        to_file.symlink_to(secret)
        assert "not a serial device" in (port_refusal(str(to_file)) or "")
        dangling = tmp_path / "dangling"
        dangling.symlink_to(tmp_path / "gone")
        assert "not a serial device" in (port_refusal(str(dangling)) or "")
        null = tmp_path / "null"
        null.symlink_to("/dev/null")  # a character device, but no terminal
        assert "not a serial device" in (port_refusal(str(null)) or "")
    finally:
        os.close(master)
        os.close(slave)


def test_the_allowing_flag_lets_the_page_open_anything() -> None:
    strict = SecurityPolicy.build(parse_listen(LOCAL), None)
    loose = SecurityPolicy.build(parse_listen(LOCAL), None, any_port=True)
    assert strict.port_refusal("socket://127.0.0.1:1") is not None
    assert loose.port_refusal("socket://127.0.0.1:1") is None


@pytest.fixture(scope="module")
def console() -> Iterator[TestClient]:
    tap = FrameTap()
    sim, bus = simulated_bus(tap, {1: 115200})
    policy = SecurityPolicy.build(parse_listen(LOCAL), None)
    with TestClient(create_app(DashboardConfig(bus, tap, policy, sim=True)), base_url=f"http://{LOCAL}") as client:
        yield client
    bus.close()
    sim.close()


def ask(ws: Any, op: str, **fields: Any) -> dict[str, Any]:
    ws.send_json({"op": op, "req": op, **fields})
    while True:
        message = ws.receive_json()
        if message.get("type") == "reply" and message.get("req") == op:
            return message  # type: ignore[no-any-return]


@pytest.mark.parametrize(
    "url", ["spy:///dev/null?file=/tmp/nurimc-victim", "socket://127.0.0.1:22", "sim://?state=/tmp/x"]
)
def test_the_page_cannot_open_files_or_the_network(console: TestClient, url: str, tmp_path: Any) -> None:
    with console.websocket_connect("/ws", headers=SAME_ORIGIN) as ws:
        answer = ask(ws, "open_bus", port=url, baudrate=115200)
        assert not answer["ok"] and "--allow-any-port" in answer["error"]
        assert ask(ws, "ports")["ok"]  # the connection goes on


def test_every_answer_forbids_framing_and_foreign_scripts(console: TestClient) -> None:
    for path, status in (("/", 200), ("/api/info", 200), ("/app.js", 200), ("/missing.js", 404)):
        response = console.get(path)
        assert response.status_code == status or (path == "/" and response.status_code == 503)  # no uPlot here
        assert response.headers["x-frame-options"] == "DENY"
        csp = response.headers["content-security-policy"]
        assert "frame-ancestors 'none'" in csp and "script-src 'self'" in csp and "unsafe-inline" not in csp
    refused = console.get("/", headers={"host": "evil.example:8485"})
    assert refused.status_code == 421 and refused.headers["x-frame-options"] == "DENY"


def test_the_page_has_no_inline_script_or_style() -> None:
    """The CSP above allows scripts and styles from files only: the page must not need more."""
    from nurimc.dashboard.server import STATIC

    html = (STATIC / "index.html").read_text(encoding="utf-8")
    assert "<script" not in html.replace('<script type="module" src="./app.js"></script>', "")
    assert "<style" not in html and " style=" not in html and "javascript:" not in html
    assert " onclick=" not in html and " onload=" not in html


# -- the connection limits, through uvicorn on loopback --------------------------------------


SLOW_STARTED = threading.Event()


async def hello_app(scope: Any, receive: Any, send: Any) -> None:
    if scope["type"] == "lifespan":
        while (await receive())["type"] != "lifespan.shutdown":
            await send({"type": "lifespan.startup.complete"})
        await send({"type": "lifespan.shutdown.complete"})
        return
    if scope["path"] == "/slow":
        SLOW_STARTED.set()
        await asyncio.sleep(2.0)
    await send({"type": "http.response.start", "status": 200, "headers": [(b"content-length", b"2")]})
    await send({"type": "http.response.body", "body": b"ok"})


class Served:
    def __init__(self, limits: ConnectionLimits) -> None:
        self.limits = limits
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(1024)
        self.port = self.sock.getsockname()[1]
        config = uvicorn.Config(hello_app, log_level="critical", **server_options(limits))
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True)
        self.thread.start()
        deadline = time.monotonic() + 30
        while not self.server.started:
            assert time.monotonic() < deadline, "server did not start"
            time.sleep(0.01)

    def close(self) -> None:
        self.server.should_exit = True
        self.thread.join(10)


@pytest.fixture
def served() -> Iterator[Served]:
    s = Served(ConnectionLimits(per_address=40, total=60, header_timeout=1.0))
    yield s
    s.close()


def get(port: int, timeout: float = 10.0) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as conn:
        conn.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n")
        data = b""
        while chunk := conn.recv(4096):
            data += chunk
        return data


def half_open(port: int, count: int) -> list[socket.socket]:
    held = []
    for _ in range(count):
        conn = socket.create_connection(("127.0.0.1", port), timeout=10)
        conn.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")  # and never the end of the headers
        held.append(conn)
    return held


def closed_by_server(conn: socket.socket, timeout: float) -> bool:
    conn.settimeout(timeout)
    try:
        return conn.recv(1) == b""
    except TimeoutError:
        return False
    except ConnectionResetError:
        return True


def test_a_half_open_connection_is_closed_after_the_header_timeout(served: Served) -> None:
    (conn,) = half_open(served.port, 1)
    started = time.monotonic()
    assert closed_by_server(conn, timeout=15.0)
    assert 0.9 <= time.monotonic() - started < 15.0
    conn.close()


def test_a_new_page_loads_past_hundreds_of_half_open_connections(served: Served) -> None:
    held = half_open(served.port, 300)  # far over both caps: the oldest are closed to make room
    try:
        assert get(served.port).endswith(b"ok")
        assert served.limits.evicted >= 300 - 60
        assert served.limits.count <= 60
    finally:
        for conn in held:
            conn.close()


def read_answer(conn: socket.socket) -> bytes:
    data = b""
    while not data.endswith(b"ok"):
        chunk = conn.recv(4096)
        if not chunk:
            break
        data += chunk
    return data


def test_a_request_in_progress_is_not_the_one_closed(served: Served) -> None:
    """Only idle connections make room: a request being answered is not cut, an idle one goes first."""
    idle = socket.create_connection(("127.0.0.1", served.port), timeout=10)
    idle.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")  # answered at once, then idle (keep-alive)
    assert read_answer(idle).endswith(b"ok")
    SLOW_STARTED.clear()
    busy = socket.create_connection(("127.0.0.1", served.port), timeout=30)
    busy.sendall(b"GET /slow HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")  # answered after 2 s
    assert SLOW_STARTED.wait(15)  # the server has it: a request in progress from now on
    held = half_open(served.port, 100)
    try:
        assert closed_by_server(idle, timeout=15.0)
        assert read_answer(busy).endswith(b"ok")
        assert get(served.port).endswith(b"ok")
    finally:
        for conn in held:
            conn.close()
        idle.close()
        busy.close()


def test_oversized_headers_are_refused() -> None:
    s = Served(ConnectionLimits(header_timeout=5.0))
    try:
        with socket.create_connection(("127.0.0.1", s.port), timeout=10) as conn:
            conn.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: " + b"a" * 40000)  # and no end in sight
            answer = conn.recv(4096)
            assert answer.startswith(b"HTTP/1.1 4"), answer
    finally:
        s.close()


def test_out_of_descriptors_is_one_line_a_minute(capsys: pytest.CaptureFixture[str]) -> None:
    import errno

    from nurimc.dashboard.connlimits import EMFILE_LOG_EVERY, quiet_emfile

    loop = asyncio.new_event_loop()
    now = [0.0]
    seen: list[dict[str, Any]] = []
    loop.set_exception_handler(lambda _loop, context: seen.append(context))
    try:
        quiet_emfile(loop, now=lambda: now[0])
        emfile = {"message": "socket.accept() out of system resource", "exception": OSError(errno.EMFILE, "Too many")}
        for second in range(120):  # asyncio retries accept() every second
            now[0] = float(second)
            loop.call_exception_handler(emfile)
        other = {"message": "something else", "exception": ValueError("x")}
        loop.call_exception_handler(other)
    finally:
        loop.close()
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 120 // int(EMFILE_LOG_EVERY) and all("out of file descriptors" in line for line in lines)
    assert "Traceback" not in "".join(lines)
    assert seen == [other]  # anything else goes to the handler that was there
