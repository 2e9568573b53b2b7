"""RFC 2217 on the simulator's TCP port: a Telnet client sets its own rate (SET-BAUDRATE), data
has its 0xFF bytes doubled both ways, and a raw client is told apart by its first bytes."""

from __future__ import annotations

import random
import socket
import struct
import time
from collections.abc import Iterator

import pytest
from serial import rfc2217 as pyserial_rfc2217

from nurimc.sim import SimBus
from nurimc.sim.rfc2217 import (
    COM_PORT_OPTION,
    DO,
    DONT,
    IAC,
    MAX_SUBNEGOTIATION,
    SB,
    SE,
    SET_BAUDRATE,
    WILL,
    WONT,
    Rfc2217Session,
    detect,
)
from nurimc.sim.tcp_server import TcpServer

from .wirehelp import frame

RATES = {1: 9600, 2: 57600, 3: 115200}


class Recorder:
    """A session's outside world: the link's rate, what went on the bus (with the rate it went
    at), the replies, the purges."""

    def __init__(self) -> None:
        self.baud = 9600
        self.bus: list[tuple[bytes, int]] = []
        self.replies = bytearray()
        self.purges = 0
        self.session = Rfc2217Session(
            get_baud=lambda: self.baud,
            set_baud=self.set_baud,
            write=lambda data: self.bus.append((data, self.baud)),
            reply=self.replies.extend,
            purge=self.purge,
        )

    def set_baud(self, rate: int) -> None:
        self.baud = rate

    def purge(self) -> None:
        self.purges += 1


def sub(command: int, value: bytes) -> bytes:
    return bytes((IAC, SB, COM_PORT_OPTION, command)) + value.replace(b"\xff", b"\xff\xff") + bytes((IAC, SE))


def test_first_bytes_tell_telnet_from_raw() -> None:
    assert detect(b"") is None and detect(b"\xff") is None
    assert detect(b"\xff\xfe\x01") is False  # a frame's header FF FE (IAC DONT) is raw
    assert detect(b"\x00\xff") is False
    for verb in (WILL, DO, WONT, SB):
        assert detect(bytes((IAC, verb))) is True


def test_negotiation_is_answered_once_and_unknown_options_refused() -> None:
    rec = Recorder()
    rec.session.feed(bytes((IAC, WILL, COM_PORT_OPTION, IAC, DO, COM_PORT_OPTION, IAC, DO, 1, IAC, WILL, 24)))
    expected = (IAC, DO, COM_PORT_OPTION, IAC, WILL, COM_PORT_OPTION, IAC, WONT, 1, IAC, DONT, 24)
    assert bytes(rec.replies) == bytes(expected)
    rec.replies.clear()
    rec.session.feed(bytes((IAC, WILL, COM_PORT_OPTION, IAC, WONT, 1)))  # no change: no answer (no loop)
    assert rec.replies == b""
    rec.session.feed(bytes((IAC, WONT, COM_PORT_OPTION)))
    assert bytes(rec.replies) == bytes((IAC, DONT, COM_PORT_OPTION))


def test_set_baudrate_applies_between_frames_and_is_answered_with_the_rate() -> None:
    rec = Recorder()
    rec.session.feed(b"\x01\x02" + sub(SET_BAUDRATE, struct.pack("!I", 115200)) + b"\x03")
    assert rec.bus == [(b"\x01\x02", 9600), (b"\x03", 115200)]
    assert bytes(rec.replies) == bytes((IAC, SB, COM_PORT_OPTION, 101)) + struct.pack("!I", 115200) + bytes((IAC, SE))
    rec.replies.clear()
    rec.session.feed(sub(SET_BAUDRATE, bytes(4)))  # 0 asks
    assert rec.baud == 115200 and bytes(rec.replies)[4:8] == struct.pack("!I", 115200)


def test_doubled_iac_is_one_data_byte_even_split_across_reads() -> None:
    rec = Recorder()
    rec.session.feed(b"\xff")
    rec.session.feed(b"\xff\xfe\x01")
    assert b"".join(data for data, _ in rec.bus) == b"\xff\xfe\x01"
    rec.session.feed(sub(12, b"\x01"))  # PURGE-DATA receive
    assert rec.purges == 1 and bytes(rec.replies)[3:5] == bytes((112, 1))


def test_garbage_never_raises_and_an_endless_subnegotiation_is_bounded() -> None:
    rng = random.Random(2217)
    rec = Recorder()
    for _ in range(3000):
        rec.session.feed(bytes(rng.choice((0xFF, 0xFA, 0xF0, 0xFB, 0xFD, 44, 1, rng.randrange(256))) for _ in range(9)))
    assert len(rec.session._sub) <= MAX_SUBNEGOTIATION
    rec = Recorder()
    rec.session.feed(bytes((IAC, SB, COM_PORT_OPTION, SET_BAUDRATE)) + struct.pack("!I", 115200) + bytes(100_000))
    assert len(rec.session._sub) == MAX_SUBNEGOTIATION and rec.bus == []
    rec.session.feed(bytes((IAC, SE)) + b"\x05")
    assert rec.bus == [(b"\x05", 9600)] and rec.replies == b""  # the overlong one dropped whole; data again


@pytest.fixture
def three_rates() -> Iterator[TcpServer]:
    sim = SimBus()
    for device_id, rate in RATES.items():
        sim.add_controller(device_id, baud=rate)
    server = sim.serve_tcp(port=0, baud=9600)
    yield server
    server.stop()
    sim.close()


def ask(port: pyserial_rfc2217.Serial, device_id: int) -> bytes:
    """Ping `device_id` and read what comes back within a second (empty: no answer)."""
    port.reset_input_buffer()
    port.write(frame(device_id, 0xA0))
    deadline = time.monotonic() + 1.0
    data = b""
    while len(data) < 6 and time.monotonic() < deadline:
        data += port.read(64)
    return data


def test_a_pyserial_rfc2217_client_changes_rate_and_reaches_three_rates(three_rates: TcpServer) -> None:
    host, tcp_port = three_rates.address
    port = pyserial_rfc2217.Serial(f"rfc2217://{host}:{tcp_port}", baudrate=9600, timeout=0.2)
    try:
        for device_id, rate in [*RATES.items(), (1, 9600)]:
            port.baudrate = rate
            (client,) = three_rates.clients.values()
            assert client.link.baud == rate  # the simulator's link follows SET-BAUDRATE
            answer = ask(port, device_id)
            assert answer[:4] == b"\xff\xfe" + bytes((device_id, 2)), (device_id, rate, answer)
        port.baudrate = 115200
        assert ask(port, 1) == b""  # the 9,600 bps controller does not hear 115,200 bps
    finally:
        port.close()
    assert three_rates.alive and three_rates.errors == 0


def test_a_raw_client_still_talks_at_the_server_rate_even_one_byte_at_a_time(three_rates: TcpServer) -> None:
    with socket.create_connection(three_rates.address, timeout=10) as conn:
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        ping = frame(1, 0xA0)
        conn.sendall(ping[:1])  # a lone 0xFF: held until the next byte tells
        deadline = time.monotonic() + 10
        while not three_rates.clients or not next(iter(three_rates.clients.values())).head:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        conn.sendall(ping[1:])
        data = b""
        while len(data) < 6:
            chunk = conn.recv(64)
            assert chunk
            data += chunk
        assert data.startswith(b"\xff\xfe\x01\x02")  # not doubled: raw
        (client,) = three_rates.clients.values()
        assert client.raw and client.session is None and client.link.baud == 9600
