"""motor.stop() and wait_until_arrived() through the library, on the sync and the asyncio bus,
against the in-process simulator under both readings of speed 0."""

from __future__ import annotations

import asyncio
import time

import pytest

from nurimc import Bus
from nurimc.drivers.aio import AsyncBus
from nurimc.errors import NotArrived
from nurimc.procedures.motor import SpeedZero


def url(speed_zero: str) -> str:
    return f"sim://?ids=1&speed_zero={speed_zero}"


def test_speed_zero_frame_is_accel_speed_with_speed_0() -> None:
    # checksum ~(01 + 06 + 03 + 00 00 00 + 05) = ~0F = F0
    assert SpeedZero(1, 0, 0, 5).encode().hex(" ") == "ff fe 01 06 f0 03 00 00 00 05"


@pytest.mark.parametrize("speed_zero", ["stop", "ignore"])
def test_sync_stop_brings_a_turning_motor_to_rest(speed_zero: str) -> None:
    with Bus.open(url(speed_zero)) as bus:
        motor = bus.motor(1)
        motor.set("resolution", 1024)
        motor.run(120, 0.2)
        deadline = time.monotonic() + 30
        while motor.read_speed() < 100:
            assert time.monotonic() < deadline
        at_rest = motor.stop(0.3)
        assert at_rest.speed < 1
        time.sleep(0.3)
        assert abs(motor.read_speed()) < 1
        assert abs(motor.read_state().device_position - at_rest.device_position) < 1
        assert motor.get("control") == "on"


@pytest.mark.parametrize("speed_zero", ["stop", "ignore"])
def test_async_move_waits_and_stop(speed_zero: str) -> None:
    async def scenario() -> None:
        async with AsyncBus.open(url(speed_zero)) as bus:
            motor = bus.motor(1)
            await motor.set("resolution", 1024)
            await motor.move_to(90, rpm=120, wait=True, timeout=10)
            assert abs((await motor.read_state()).device_position - 90) <= 1
            await motor.move_by(-30, seconds=0.5)
            state = await motor.wait_until_arrived(10)
            assert abs(state.device_position - 60) <= 1
            await motor.run(-120, 0.2)
            await asyncio.sleep(0.5)
            assert (await motor.stop()).speed < 1

    asyncio.run(scenario())


def test_a_move_that_cannot_arrive_in_time_raises_not_arrived() -> None:
    with Bus.open(url("stop")) as bus:
        motor = bus.motor(1)
        motor.set("resolution", 1024)
        with pytest.raises(NotArrived, match=r"ID 1: not at -300° after 0.2 s \(it reads"):
            motor.move_to(-300, rpm=5, wait=True, timeout=0.2)
        motor.stop()


@pytest.mark.parametrize("speed_zero", ["stop", "ignore"])
def test_stop_in_relative_position_mode(speed_zero: str) -> None:
    """In relative mode hold() only turns control on; stop() adds a step of 0, which holds."""
    with Bus.open(url(speed_zero)) as bus:
        motor = bus.motor(1)
        motor.set("resolution", 1024)
        motor.set("position-mode", "relative")
        motor.run(120, 0.2)
        time.sleep(0.6)
        at_rest = motor.stop()
        time.sleep(0.3)
        assert abs(motor.read_speed()) < 1
        assert abs(motor.read_state().device_position - at_rest.device_position) < 1
