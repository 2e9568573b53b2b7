"""Seeded faults are reproducible; arbitrary host bytes never crash or wedge the bus model."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.core.clock import VirtualClock
from nurimc.sim import FaultConfig, SimBus

from .wirehelp import frame, parse_answer


def traffic(faults: FaultConfig, seed: int) -> bytes:
    clock = VirtualClock(0.0)
    bus = SimBus(clock=clock, faults=faults, seed=seed)
    for i in range(3):
        bus.add_controller(i)
    port = bus.open_serial(timeout=0)
    received = bytearray()
    for n in range(60):
        port.write(frame(n % 3, 0xA0 + n % 12))
        clock.t += 0.05
        received += port.read(1000)
    return bytes(received)


FAULTS = FaultConfig(drop_rate=0.02, flip_rate=0.02, noise_rate=0.01, delay_ms=3, delay_rate=0.2, miss_rate=0.1)


def test_faults_are_reproducible_by_seed() -> None:
    clean = traffic(FaultConfig(), 0)
    first, again, other = traffic(FAULTS, 1), traffic(FAULTS, 1), traffic(FAULTS, 2)
    assert first == again
    assert first != clean
    assert first != other


@pytest.mark.parametrize(
    ("faults", "effect"),
    [
        (FaultConfig(miss_rate=1.0), lambda raw: raw == b""),
        (FaultConfig(drop_rate=1.0), lambda raw: raw == b""),
        (FaultConfig(echo=True), lambda raw: raw == frame(0, 0xA0) + frame(0, 0xD0)),
        (FaultConfig(flip_rate=1.0), lambda raw: raw == b""),  # every request byte is hit: no answer
        (FaultConfig(noise_rate=1.0, noise_max=1), lambda raw: len(raw) >= 7),
    ],
    ids=["miss", "drop", "echo", "flip", "noise"],
)
def test_each_fault_has_its_effect(faults: FaultConfig, effect: object) -> None:
    clock = VirtualClock(0.0)
    bus = SimBus(clock=clock, faults=faults)
    bus.add_controller(0)
    port = bus.open_serial(timeout=0)
    port.write(frame(0, 0xA0))
    clock.t += 0.01
    raw = port.read(100)
    assert callable(effect) and effect(raw), raw.hex(" ")


def test_flipped_answer_bytes_reach_the_host_corrupted() -> None:
    clock = VirtualClock(0.0)
    bus = SimBus(clock=clock, faults=FaultConfig(flip_rate=0.3), seed=5)
    bus.add_controller(0)
    port = bus.open_serial(timeout=0)
    corrupted = 0
    for _ in range(40):
        port.write(frame(0, 0xA0))
        clock.t += 0.01
        raw = port.read(100)
        if len(raw) == 6 and parse_answer(raw, 0, 0xA0) is None:
            corrupted += 1
    assert corrupted > 0
    assert bus.faults.counts["flipped"] > corrupted


def test_delay_fault_delays_answers() -> None:
    clock = VirtualClock(0.0)
    bus = SimBus(clock=clock, faults=FaultConfig(delay_ms=30))
    bus.add_controller(0)
    port = bus.open_serial(timeout=0)
    port.write(frame(0, 0xA0))
    clock.t += 0.02
    assert port.read(100) == b""
    clock.t += 0.02
    assert port.read(100) == frame(0, 0xD0)


def test_fault_config_rejects_nonsense() -> None:
    with pytest.raises(ValueError, match="drop_rate"):
        FaultConfig(drop_rate=1.5)


@settings(max_examples=150, deadline=None)
@given(chunks=st.lists(st.binary(max_size=80), max_size=8), baud=st.sampled_from([9600, 115200, 300]))
def test_fuzzed_host_bytes_never_crash_or_wedge(chunks: list[bytes], baud: int) -> None:
    clock = VirtualClock(0.0)
    bus = SimBus(clock=clock, eeprom_time=0.05)
    bus.add_controller(0, 9600)
    bus.add_controller(1, 115200, "blmc-h")
    port = bus.open_serial(baudrate=baud, timeout=0)
    headered = [b"\xff\xfe" + c for c in chunks]  # make frames plausible, not just noise
    for chunk in headered:
        port.write(chunk)
        clock.t += 0.003
        port.read(10_000)
    clock.t += 0.5  # past any EEPROM write
    bus.advance()
    for controller in bus.controllers:
        # the host may have changed its ID or rate on the way; ask it where it is now
        port.baudrate = controller.baud
        port.reset_input_buffer()
        port.write(frame(controller.id, 0xA0))
        clock.t += 0.05
        raw = port.read(10_000)
        assert frame(controller.id, 0xD0) in raw, (controller, raw.hex(" "))
