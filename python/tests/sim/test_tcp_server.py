"""The simulator's TCP server under many clients and a client that does not read (issue 39,
item 7): no FD_SETSIZE death past 1,024 sockets, a client cap, a bounded buffer per client."""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from nurimc.sim import SimBus
from nurimc.sim.tcp_server import TcpServer

from .wirehelp import frame

PING = frame(1, 0xA0)  # a ping of ID 1
ANSWER = 6  # its answer: FF FE 01 02 checksum D0


@pytest.fixture
def bus() -> Iterator[SimBus]:
    sim = SimBus()
    sim.add_controller(1)
    yield sim
    sim.close()


def answered(server: TcpServer, timeout: float = 10.0) -> bool:
    """A new client asks ID 1 once and gets the whole answer."""
    with socket.create_connection(server.address, timeout=timeout) as conn:
        conn.sendall(PING)
        data = b""
        deadline = time.monotonic() + timeout
        while len(data) < ANSWER and time.monotonic() < deadline:
            chunk = conn.recv(64)
            if not chunk:
                return False
            data += chunk
        return data.startswith(b"\xff\xfe\x01")


def closed_by_server(conn: socket.socket, timeout: float = 10.0) -> bool:
    """The server closed it (what it had sent before is read and thrown away)."""
    conn.settimeout(timeout)
    try:
        while conn.recv(65536):
            pass
        return True
    except TimeoutError:
        return False
    except ConnectionResetError:
        return True


def test_a_new_client_is_served_after_1100_connections(bus: SimBus) -> None:
    server = bus.serve_tcp(port=0, max_clients=1200)
    held: list[socket.socket] = []
    try:
        for _ in range(1100):  # past select()'s FD_SETSIZE of 1,024
            held.append(socket.create_connection(server.address, timeout=10))
        deadline = time.monotonic() + 30
        while len(server.clients) < 1100:
            assert time.monotonic() < deadline, f"only {len(server.clients)} accepted"
            time.sleep(0.01)
        assert answered(server)
        assert server.alive and server.errors == 0
    finally:
        for conn in held:
            conn.close()
        server.stop()


def test_connections_over_the_cap_are_closed_and_the_server_goes_on(bus: SimBus) -> None:
    server = bus.serve_tcp(port=0, max_clients=5)
    held = [socket.create_connection(server.address, timeout=10) for _ in range(10)]
    try:
        closed = [conn for conn in held[5:] if closed_by_server(conn)]
        assert len(closed) == 5 and server.refused == 5
        for conn in held[:5]:
            conn.close()
        deadline = time.monotonic() + 10
        while server.clients:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert answered(server) and server.alive
    finally:
        for conn in held:
            conn.close()
        server.stop()


def test_a_client_that_does_not_read_is_dropped_and_stalls_no_one(bus: SimBus) -> None:
    """Every client of a monitor server hears what the others send: one sends 1 MiB, one never
    reads. The one that does not read is dropped; the other goes on and is answered."""
    server = TcpServer(bus, "127.0.0.1", 0, 9600, monitor=True, max_pending=4096).start()
    sleeper = socket.socket()
    sleeper.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)  # and it never reads
    sleeper.connect(server.address)
    heard = bytearray()
    try:
        with socket.create_connection(server.address, timeout=10) as active:

            def drain() -> None:
                with contextlib.suppress(OSError):
                    while data := active.recv(65536):
                        heard.extend(data)

            reader = threading.Thread(target=drain, daemon=True)
            reader.start()
            active.sendall(bytes(1 << 20))
            deadline = time.monotonic() + 20
            while server.dropped == 0:
                assert time.monotonic() < deadline, "the client that does not read was not dropped"
                time.sleep(0.01)
            assert server.dropped == 1 and closed_by_server(sleeper)
            active.sendall(PING)
            deadline = time.monotonic() + 20
            while not answer_in(bytes(heard)):
                assert time.monotonic() < deadline, "the active client is not answered"
                time.sleep(0.01)
            assert server.alive and server.errors == 0
    finally:
        sleeper.close()
        server.stop()


def answer_in(data: bytes) -> bool:
    """ID 1's answer to the ping (mode D0) among the bytes heard (a monitor hears the ping too)."""
    at = data.find(b"\xff\xfe\x01\x02")
    while at >= 0:
        if data[at + 5 : at + 6] == b"\xd0":
            return True
        at = data.find(b"\xff\xfe\x01\x02", at + 1)
    return False
