"""The bus model: collisions, broadcast, wire timing (a fake clock keeps these exact)."""

from __future__ import annotations

from collections.abc import Callable

from nurimc.core.clock import VirtualClock
from nurimc.sim import SimBus

from .conftest import Pty
from .wirehelp import ask, command, frame, parse_answer, silent, u16


def test_duplicate_ids_garble_answers(make_pty: Callable[..., Pty]) -> None:
    port = make_pty([(0, 9600), (0, 9600)]).open()
    port.write(frame(0, 0xA0))
    raw = port.read(64)
    assert raw  # both answered ...
    assert parse_answer(raw, 0, 0xA0) is None  # ... on top of each other
    assert raw != frame(0, 0xD0) + frame(0, 0xD0)


def test_duplicate_ids_staggered_by_response_time_answer_cleanly(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty([(0, 9600), (1, 9600)])
    port = pty.open()
    command(port, 1, "set_response_time", bytes([200]))  # 20 ms: longer than a 6-byte answer (6.25 ms)
    assert ask(port, 1, 0xA5) == bytes([200])
    command(port, 1, "set_id", bytes([0]))  # now two controllers at ID 0
    assert ask(port, 0, 0xA0) is not None
    port.read(64)  # drain the second (later) answer, or it would collide with the next one
    port.reset_input_buffer()
    port.write(frame(0, 0xA0))
    assert port.read(12) == frame(0, 0xD0) * 2


def test_broadcast_commands_reach_every_controller(make_pty: Callable[..., Pty]) -> None:
    port = make_pty([(0, 9600), (1, 9600), (2, 9600)]).open()
    command(port, 0xFF, "set_rated_speed", u16(777))
    port.timeout = 0.2
    assert port.read(16) == b""  # nobody answers a command
    for ident in range(3):
        assert ask(port, ident, 0xA6) == u16(777)


def test_broadcast_request_collides_unless_staggered() -> None:
    clock = VirtualClock()
    bus = SimBus(clock=clock, eeprom_time=0.0)
    for i in range(3):
        bus.add_controller(i)
    port = bus.open_serial(timeout=0)
    port.write(frame(0xFF, 0xA0))
    clock.t += 0.1
    garbled = port.read(100)
    assert garbled and b"".join(frame(i, 0xD0) for i in range(3)) != garbled
    for i in range(3):
        port.write(frame(i, 0x08, bytes([1 + 100 * i])))  # 0.1, 10.1, 20.1 ms apart
    clock.t += 0.1
    port.write(frame(0xFF, 0xA0))
    clock.t += 0.1
    assert port.read(100) == b"".join(frame(i, 0xD0) for i in range(3))
    assert bus.collisions == 1


def test_wire_timing_paces_each_byte() -> None:
    clock = VirtualClock()
    bus = SimBus(clock=clock, wire_timing=True)
    bus.add_controller(0, 9600)
    port = bus.open_serial(baudrate=9600, timeout=0)
    start = clock.t
    port.write(frame(0, 0xA0))
    byte = 10 / 9600
    answer_start = start + 6 * byte + 100e-6
    clock.t = answer_start + 5.5 * byte
    assert port.read(100) == frame(0, 0xD0)[:5]
    clock.t = answer_start + 6 * byte + 1e-9
    assert port.read(100) == frame(0, 0xD0)[5:]


def test_without_wire_timing_only_the_response_time_counts() -> None:
    clock = VirtualClock()
    bus = SimBus(clock=clock)
    c = bus.add_controller(0, 9600)
    c.settings.response_time = 50  # 5 ms
    port = bus.open_serial(timeout=0)
    port.write(frame(0, 0xA0))
    clock.t += 0.0049
    assert port.read(10) == b""
    clock.t += 0.0002
    assert port.read(10) == frame(0, 0xD0)


def test_wrong_rate_host_gives_garbage_not_frames(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty([(0, 9600)])
    port = pty.open(19200)
    for _ in range(5):
        assert silent(port, 0, 0xA0, wait=0.05)
    assert pty.bus.rejected[9600] > 0  # the controller heard garbage, not frames
    assert pty.bus.controllers[0].frames_received == 0
