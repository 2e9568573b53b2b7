"""One API for sync and asyncio (issue 17.2): the same public methods, with the same
signatures, on Motor/AsyncMotor, Bus/AsyncBus and Group/AsyncGroup; and byte listeners kept
as a list, so a traffic log and a tracer given together both see every byte."""

from __future__ import annotations

import asyncio
import inspect
import json
from pathlib import Path

import pytest

from nurimc import AsyncBus, AsyncGroup, AsyncMotor, Bus, Group, Motor
from nurimc.protocol import (
    Message,
    Ping,
    PositionFeedback,
    RequestPing,
    RequestPosition,
    RequestSpeed,
    SpeedFeedback,
    decode,
)

from .fakes import ScriptedTransport

ANSWER = PositionFeedback(3, 0, 18000, 15, 2)
PAIRS = [(Motor, AsyncMotor), (Bus, AsyncBus), (Group, AsyncGroup)]


def public(cls: type) -> dict[str, object]:
    return {name: inspect.getattr_static(cls, name) for name in dir(cls) if not name.startswith("_")}


def instance_attributes(make: object) -> set[str]:
    return {name for name in vars(make) if not name.startswith("_")}


@pytest.mark.parametrize(("sync", "aio"), PAIRS, ids=lambda c: c.__name__)
def test_the_same_public_methods(sync: type, aio: type) -> None:
    sync_api, async_api = public(sync), public(aio)
    assert set(sync_api) == set(async_api), set(sync_api) ^ set(async_api)
    for name, member in sync_api.items():
        other = async_api[name]
        assert type(member) is type(other), name  # function, property, classmethod, motor call
        if inspect.isfunction(member):
            assert inspect.iscoroutinefunction(other) or not inspect.iscoroutinefunction(member), name
            s_sig, a_sig = inspect.signature(member), inspect.signature(other)  # type: ignore[arg-type]
            assert [(p.name, p.default) for p in s_sig.parameters.values()] == [
                (p.name, p.default) for p in a_sig.parameters.values()
            ], name


ANSWERS: dict[Message, Message] = {
    RequestPosition(3): ANSWER,
    RequestPing(3): Ping(3),
    RequestSpeed(3): SpeedFeedback(3, 1, 125, 0, 0),
}


def scripted() -> ScriptedTransport:
    return ScriptedTransport(lambda data: answer.encode() if (answer := ANSWERS.get(decode(data))) else b"")


def test_motor_handles_have_the_same_calls_and_instance_attributes() -> None:
    sync_motor = Bus(scripted()).motor(3)
    async_motor = AsyncBus(scripted()).motor(3)
    assert instance_attributes(sync_motor) == instance_attributes(async_motor)
    calls = [n for n in dir(Motor) if not n.startswith("_") and callable(getattr(sync_motor, n))]
    for required in ("ping", "read_speed", "read_settings", "read_state", "get", "set", "hold", "release"):
        assert required in calls
    for name in calls:
        if name.startswith("make_"):
            assert not inspect.iscoroutinefunction(getattr(async_motor, name))
            continue
        # the async handle's call returns an awaitable; the sync one runs now
        result = getattr(async_motor, name)
        assert inspect.signature(result) == inspect.signature(getattr(sync_motor, name)), name


def test_sync_and_async_motors_give_the_same_answers() -> None:
    sync_motor = Bus(scripted()).motor(3)

    async def read() -> tuple[object, bool, float]:
        motor = AsyncBus(scripted()).motor(3)
        return await motor.read_state(), await motor.ping(), await motor.read_speed()

    assert asyncio.run(read()) == (sync_motor.read_state(), True, -12.5)
    assert (sync_motor.ping(), sync_motor.read_speed()) == (True, -12.5)


class Tracer:
    def __init__(self) -> None:
        self.seen: list[tuple[str, bytes]] = []
        self.closed = False

    def record(self, direction: str, data: bytes) -> None:
        self.seen.append((direction, data))

    def close(self) -> None:
        self.closed = True


def logged(path: Path) -> list[tuple[str, bytes]]:
    return [(e["dir"], bytes.fromhex(e["hex"])) for e in map(json.loads, path.read_text().splitlines())]


def test_log_path_and_tracer_are_both_kept(tmp_path: Path) -> None:
    tracer, extra = Tracer(), Tracer()
    bus = Bus(scripted(), log_path=str(tmp_path / "sync.log"), tracer=tracer, listeners=[extra])
    assert len(bus.listeners) == 3
    bus.motor(3).read_state()
    bus.close()
    expected = [("tx", RequestPosition(3).encode()), ("rx", ANSWER.encode())]
    assert tracer.seen == extra.seen == logged(tmp_path / "sync.log") == expected
    assert tracer.closed and extra.closed


def test_async_bus_keeps_log_path_and_tracer_too(tmp_path: Path) -> None:
    tracer, late = Tracer(), Tracer()

    async def main() -> None:
        bus = AsyncBus(scripted(), log_path=str(tmp_path / "async.log"), tracer=tracer)
        bus.add_listener(late)
        await bus.motor(3).read_state()
        bus.remove_listener(late)
        await bus.motor(3).read_state()
        await bus.close()

    asyncio.run(main())
    one = [("tx", RequestPosition(3).encode()), ("rx", ANSWER.encode())]
    assert tracer.seen == logged(tmp_path / "async.log") == one * 2
    assert late.seen == one and not late.closed  # removed before close: not the bus's to close
