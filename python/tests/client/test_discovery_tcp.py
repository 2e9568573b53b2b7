"""Discovery over TCP: the simulator's --tcp port (socket://), a proxy in front of it, and a
serial server whose network holds a request back (ser2net in front of a real RS485 bus).

Controllers that share a rate answer the broadcast ping together, so the IDs are walked one
request at a time. Over TCP each request must reach the bus on its own: a request held back
until the next one (Nagle's algorithm on the host's socket, or the network) puts both on the
wire back to back, and the two controllers' answers collide.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections.abc import Iterator

import pytest

from nurimc import Bus
from nurimc.errors import FixedRate
from nurimc.procedures.discovery import FixedLink, Found, Progress, RateSkipped, discover
from nurimc.protocol import RequestFirmware
from nurimc.sim import SimBus
from nurimc.sim.faultproxy import FaultProxy

RATE = 115200


@contextlib.contextmanager
def tcp_sim(ids: list[int], wire_timing: bool = True) -> Iterator[tuple[str, int]]:
    """A simulator with these controllers at RATE, served on a loopback TCP port."""
    sim = SimBus(wire_timing=wire_timing)
    for device_id in ids:
        sim.add_controller(id=device_id, baud=RATE)
    server = sim.serve_tcp(host="127.0.0.1", port=0, baud=RATE)
    try:
        yield server.address[0], server.address[1]
    finally:
        server.stop()
        sim.close()


def discover_at(url: str, **options: float) -> list[tuple[int, int, bool]]:
    bus = Bus.open(url, RATE, **options)
    try:
        found: list[Found] = bus.run(discover(bus.core, [RATE], lines=False))
    finally:
        bus.close()
    return [(f.id, f.baudrate, f.collision) for f in found]


@pytest.mark.parametrize("ids", [[1, 2], [1, 2, 3]], ids=["two", "three"])
@pytest.mark.parametrize("wire_timing", [True, False], ids=["wire-timed", "instant"])
def test_controllers_sharing_a_rate_are_found_over_socket(ids: list[int], wire_timing: bool) -> None:
    with tcp_sim(ids, wire_timing) as (host, port):
        assert discover_at(f"socket://{host}:{port}") == [(i, RATE, False) for i in ids]


def test_controllers_sharing_a_rate_are_found_through_the_fault_proxy() -> None:
    with tcp_sim([1, 2]) as upstream:
        proxy = FaultProxy(upstream, tcp_port=0).start()
        try:
            assert discover_at(proxy.url, latency=0.01) == [(1, RATE, False), (2, RATE, False)]
        finally:
            proxy.stop()


class HoldingRelay:
    """A TCP relay (a serial server's network) that holds the host's first chunk containing
    `hold` for `delay` seconds; what the host writes meanwhile waits behind it (TCP keeps the
    order), so that request and the next reach the bus together."""

    def __init__(self, upstream: tuple[str, int], hold: bytes, delay: float) -> None:
        self.upstream, self.hold, self.delay = upstream, hold, delay
        self.held = False
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self._threads = [threading.Thread(target=self._accept, daemon=True)]
        self._threads[0].start()

    def _accept(self) -> None:
        with contextlib.suppress(OSError):
            host, _ = self.listener.accept()
            bus = socket.create_connection(self.upstream)
            for sock in (host, bus):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            for source, sink, holding in ((host, bus, True), (bus, host, False)):
                thread = threading.Thread(target=self._carry, args=(source, sink, holding), daemon=True)
                thread.start()
                self._threads.append(thread)

    def _carry(self, source: socket.socket, sink: socket.socket, holding: bool) -> None:
        with contextlib.suppress(OSError):
            while data := source.recv(4096):
                if holding and not self.held and self.hold in data:
                    self.held = True
                    time.sleep(self.delay)
                sink.sendall(data)
        with contextlib.suppress(OSError):
            sink.shutdown(socket.SHUT_WR)

    def close(self) -> None:
        self.listener.close()


def test_a_request_held_back_by_the_network_finds_no_phantom() -> None:
    """The walk's request to ID 1 is held 30 ms (a jitter spike, longer than the walk waits per
    ID): it reaches the bus together with the request to ID 2 and the answers collide. The
    garbled bytes are not taken for a controller: the IDs that may have sent them are asked
    alone, and 1 and 2 are found, with no collision."""
    with tcp_sim([1, 2]) as upstream:
        relay = HoldingRelay(upstream, RequestFirmware(1).encode(), 0.03)
        try:
            assert discover_at(f"socket://127.0.0.1:{relay.port}") == [(1, RATE, False), (2, RATE, False)]
            assert relay.held
        finally:
            relay.close()


def test_two_controllers_at_one_id_are_still_a_collision_over_socket() -> None:
    """Asked alone, an ID two controllers share garbles again: that is a collision, reported."""
    with tcp_sim([4, 4, 7]) as (host, port):
        assert discover_at(f"socket://{host}:{port}") == [(4, RATE, True), (7, RATE, False)]


def test_a_socket_port_sends_each_write_at_once() -> None:
    """Nagle's algorithm off on socket:// (pyserial leaves it on): a request that gets no answer
    is acked only after the peer's delayed-ack timer, and a small write after it would wait
    for that ack, then go out together with the next request."""
    with tcp_sim([1]) as (host, port):
        bus = Bus.open(f"socket://{host}:{port}", RATE)
        try:
            sock = bus.transport.port._socket  # type: ignore[attr-defined]
            assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        finally:
            bus.close()


def test_a_search_over_a_tcp_gateway_is_made_once_at_its_rate() -> None:
    """The issue's case: the 18-rate search over socket:// "found" every motor at every rate.
    The link runs at the gateway's rate: one search there, each motor once, said in a note."""
    with tcp_sim([1, 2, 3]) as (host, port):
        bus = Bus.open(f"socket://{host}:{port}", RATE)
        notes: list[object] = []
        try:
            found = bus.run(discover(bus.core, lines=False), on_note=notes.append)
            assert bus.baudrate == RATE
        finally:
            bus.close()
    assert [(f.id, f.baudrate) for f in found] == [(1, RATE), (2, RATE), (3, RATE)]
    links = [n for n in notes if isinstance(n, FixedLink)]
    assert len(links) == 1 and links[0].rate == RATE and "TCP gateway" in links[0].reason
    assert not [n for n in notes if isinstance(n, RateSkipped)]  # not 17 notes: one
    searched = {n.rate for n in notes if isinstance(n, Progress)}
    assert searched == {RATE}


def test_a_tcp_gateway_refuses_another_rate_and_keeps_its_own() -> None:
    with tcp_sim([1]) as (host, port):
        bus = Bus.open(f"socket://{host}:{port}", RATE)
        try:
            with pytest.raises(FixedRate, match="set on the gateway"):
                bus.baudrate = 9600
            assert bus.baudrate == RATE
            assert bus.request(RequestFirmware(1)).id == 1  # still talking at its rate
        finally:
            bus.close()
