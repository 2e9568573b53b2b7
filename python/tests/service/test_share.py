"""Sharing a bus over the holder's Unix socket (docs/service.md, "Sharing"), in process."""

from __future__ import annotations

import os
import socket
import stat
import struct
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from nurimc.core.clock import REAL_CLOCK
from nurimc.service import BusService
from nurimc.service.share import AttachedBus, HolderGone, ShareError, ShareServer, connect, socket_path
from nurimc.sim import SimBus

from ..client.simfixtures import sim_bus

PORT = "/dev/nurimc-shared-test"  # no such device: the holder below serves a simulated bus under this name
RATE = 115200


@pytest.fixture
def holder(monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[SimBus, BusService, ShareServer]]:
    runtime = tempfile.TemporaryDirectory(dir="/tmp", prefix="nmc")  # a socket's path must stay short
    monkeypatch.setenv("XDG_RUNTIME_DIR", runtime.name)
    sim, bus = sim_bus([1, 2], baud=RATE, clock=REAL_CLOCK)
    service = BusService(bus, motors={1: RATE, 2: RATE}, program="test-holder").start()
    server = ShareServer(service, PORT, say=lambda text: None).start()
    yield sim, service, server
    server.close()
    service.close()
    bus.close()
    sim.close()
    runtime.cleanup()


def attach(program: str = "test-client", events: list[dict[str, Any]] | None = None) -> AttachedBus:
    conn = connect(PORT, program, events.append if events is not None else None)
    assert conn is not None
    return AttachedBus(conn, PORT, RATE)


def test_the_socket_is_private_and_named_after_the_port(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    path = socket_path(PORT)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    assert "nurimc-shared-test" in path.name


def test_an_attached_program_runs_commands_and_sees_the_holders_clients(
    holder: tuple[SimBus, BusService, ShareServer],
) -> None:
    sim, _, _ = holder
    bus = attach()
    try:
        state = bus.motor(1).read_state()
        assert state.id == 1
        bus.motor(2).set("response_time", 500)  # a setting written through the holder, read back
        assert sim.controller(2).settings.response_time == 5
        names = sorted(c["program"] for c in bus.clients())
        assert names == ["test-client", "test-holder"]
        mine = next(c for c in bus.clients() if c["program"] == "test-client")
        assert mine["pid"] == os.getpid() and mine["requests"] >= 2
    finally:
        bus.close()


def test_an_estop_from_an_attached_program_stops_every_motor_and_latches(
    holder: tuple[SimBus, BusService, ShareServer],
) -> None:
    sim, service, _ = holder
    events: list[dict[str, Any]] = []
    bus = attach(events=events)
    try:
        bus.motor(1).run(30)
        service.run(service.motor(2).procedures.run(30), commands=[2])
        assert not sim.controller(1).settings.control and not sim.controller(2).settings.control
        result = bus.emergency_stop()
        assert result["ok"] and result["stopped"] == [1, 2] and result["not_confirmed"] == []
        assert sim.controller(1).settings.control and sim.controller(2).settings.control
        assert service.latched == {1, 2}
        bus.motor(1).run(10)  # commanded again through the holder: its latch clears
        assert service.latched == {2}
    finally:
        bus.close()


def test_a_second_holder_cannot_start(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    _, service, _ = holder
    with pytest.raises(ShareError, match="already holds"):
        ShareServer(service, PORT).start()


def test_garbage_and_floods_drop_that_client_only(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    bus = attach()
    try:
        path = str(socket_path(PORT))
        for junk in (b"\x00\x00\x00\x05hello", struct.pack(">I", 1 << 30) + b"x", b"\xff" * 10):
            rogue = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            rogue.connect(path)
            rogue.sendall(junk)
            rogue.settimeout(5)
            with pytest.raises((ConnectionError, OSError, struct.error)):
                while True:  # the holder answers, then closes: read until it does
                    if not rogue.recv(4096):
                        raise ConnectionResetError
            rogue.close()
        assert bus.motor(1).read_state().id == 1  # the holder and the other client go on
    finally:
        bus.close()


def test_a_different_version_is_refused_clearly(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    from nurimc.service.share import PROTOCOL, recv_message, send_message

    rogue = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    rogue.connect(str(socket_path(PORT)))
    send_message(rogue, {"op": "hello", "program": "old", "pid": 1, "version": "0.0.1", "protocol": PROTOCOL})
    answer = recv_message(rogue)
    rogue.close()
    assert not answer["ok"] and "nurimc 0.0.1" in answer["error"] and "same version" in answer["error"]


def test_the_holder_ending_is_told_and_a_call_fails_clearly(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    _, _, server = holder
    events: list[dict[str, Any]] = []
    bus = attach(events=events)
    try:
        server.close()
        with pytest.raises(HolderGone, match="run the command again"):
            for _ in range(100):
                bus.motor(1).read_state()
        assert any(e["type"] == "closed" for e in events)
        assert connect(PORT, "late") is None  # nothing left to attach to
    finally:
        bus.close()


def test_a_stale_socket_is_removed_not_attached_to(monkeypatch: pytest.MonkeyPatch) -> None:
    short = tempfile.TemporaryDirectory(dir="/tmp", prefix="nmc")
    monkeypatch.setenv("XDG_RUNTIME_DIR", short.name)
    path = socket_path(PORT)
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(path))  # bound, never listening: as a crashed holder leaves it
    dead.close()
    assert path.exists()
    assert connect(PORT, "probe") is None
    assert not path.exists()
    short.cleanup()


def test_socket_tests_are_marked_realtime_by_the_conftest_rule(request: pytest.FixtureRequest) -> None:
    assert request.node.get_closest_marker("realtime") is not None


def test_the_rule_leaves_virtual_time_modules_alone() -> None:
    from .. import conftest
    from . import test_service_core

    assert not conftest.uses_real_time(test_service_core)
    assert conftest.uses_real_time(sys.modules[__name__])


def test_a_long_port_name_still_makes_a_short_socket_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with tempfile.TemporaryDirectory(dir="/tmp") as short:
        monkeypatch.setenv("XDG_RUNTIME_DIR", short)
        long_port = "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0" * 2
        path = socket_path(long_port)
        assert len(str(path)) <= 100 and path != socket_path(long_port + "x")
    deep = tmp_path / ("d" * 90)
    deep.mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(deep))
    with pytest.raises(ShareError, match="set XDG_RUNTIME_DIR to a shorter directory"):
        socket_path("/dev/ttyUSB0")


def test_in_process_buses_are_never_shared() -> None:
    from nurimc.service.share import shareable

    assert not shareable("sim://?ids=1,&baud=115200") and not shareable("loop://")
    assert shareable("/dev/ttyUSB0") and shareable("socket://127.0.0.1:5000")


def test_library_users_attach_with_open_shared(holder: tuple[SimBus, BusService, ShareServer]) -> None:
    from nurimc.drivers.sync import Bus
    from nurimc.service.share import open_shared

    shared = open_shared(PORT, RATE, program="my-script")
    try:
        assert isinstance(shared, AttachedBus) and shared.motor(1).read_state().id == 1
        assert "my-script" in {c["program"] for c in shared.clients()}
    finally:
        shared.close()
    own = open_shared("loop://", RATE)
    try:
        assert type(own) is Bus  # nobody holds it (and loop:// is never shared): opened as usual
    finally:
        own.close()
