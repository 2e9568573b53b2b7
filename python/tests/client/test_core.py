"""The request/answer engine against scripted wire behaviour: echo, noise, stale and wrong answers."""

from __future__ import annotations

import asyncio

import pytest

from nurimc import AsyncBus, Bus, CorruptedAnswer, NoAnswer, UnexpectedAnswer
from nurimc.core.timing import Timing
from nurimc.protocol import PositionFeedback, RequestPosition, SetControl, decode

from .fakes import ScriptedTransport

ANSWER = PositionFeedback(3, 0, 18000, 15, 2)


def answering(*, echo: bool = False, noise: bytes = b"", stale: bytes = b"") -> ScriptedTransport:
    def respond(data: bytes) -> bytes:
        if decode(data) == RequestPosition(3):
            return (data if echo else b"") + noise + stale + ANSWER.encode()
        return b""

    return ScriptedTransport(respond)


def test_answer_is_returned() -> None:
    bus = Bus(answering())
    assert bus.request(RequestPosition(3)) == ANSWER
    assert bus.stats.requests == 1 and bus.stats.answers == 1


def test_echo_noise_and_stale_frames_are_skipped() -> None:
    stale = PositionFeedback(4, 0, 1, 1, 1).encode()
    bus = Bus(answering(echo=True, noise=b"\x00\xff\x13", stale=stale))
    assert bus.request(RequestPosition(3)) == ANSWER
    assert bus.stats.echo_frames == 1
    assert bus.stats.dropped_bytes == 3


def test_stale_bytes_before_the_request_are_discarded() -> None:
    transport = answering()
    transport.inbox += PositionFeedback(3, 1, 999, 0, 0).encode()  # a late answer from before
    assert Bus(transport).request(RequestPosition(3)) == ANSWER


def test_no_answer_is_retried_then_reported_with_causes() -> None:
    transport = ScriptedTransport(lambda data: b"")
    bus = Bus(transport, retries=2)
    with pytest.raises(NoAnswer) as err:
        bus.request(RequestPosition(3))
    assert len(transport.written) == 3
    assert "ID 3" in str(err.value) and "baud" in str(err.value) and "wires" in str(err.value)


def test_corrupted_answer_is_never_returned_as_a_value() -> None:
    raw = bytearray(ANSWER.encode())
    raw[7] ^= 0x10  # one flipped bit in the position
    bus = Bus(ScriptedTransport(lambda data: bytes(raw)), retries=1)
    with pytest.raises(CorruptedAnswer, match="bad checksum"):
        bus.request(RequestPosition(3))


def test_wrong_id_answer_is_unexpected() -> None:
    other = PositionFeedback(9, 0, 1, 1, 1).encode()
    bus = Bus(ScriptedTransport(lambda data: other), retries=0)
    with pytest.raises(UnexpectedAnswer, match="ID 9"):
        bus.request(RequestPosition(3))


def test_flaky_wire_recovers_on_retry() -> None:
    calls = {"n": 0}

    def respond(data: bytes) -> bytes:
        calls["n"] += 1
        return b"" if calls["n"] == 1 else ANSWER.encode()

    assert Bus(ScriptedTransport(respond), retries=1).request(RequestPosition(3)) == ANSWER


def test_commands_are_sent_once_back_to_back() -> None:
    transport = ScriptedTransport(lambda data: b"")
    Bus(transport).send(SetControl(1, 1), SetControl(2, 1))
    assert transport.written == [SetControl(1, 1).encode() + SetControl(2, 1).encode()]


def test_deadline_follows_the_wire() -> None:
    timing = Timing(latency=0.001, margin=0.0, assumed_response_time=0.0001)
    # 6 + 12 bytes at 9600 bps = 18.75 ms, + 0.1 ms response + 2 x 1 ms latency
    assert timing.answer_deadline(6, 12, 9600, None) == pytest.approx(0.02085)
    assert timing.answer_deadline(6, 12, 1_000_000, 0.0001) == pytest.approx(0.00228)


def test_async_bus_runs_the_same_core() -> None:
    async def main() -> None:
        bus = AsyncBus(answering(echo=True))
        assert await bus.request(RequestPosition(3)) == ANSWER
        assert bus.core.stats.echo_frames == 1
        state = await bus.motor(3).read_state()
        assert state.position == 180.0 and state.speed == 1.5 and state.current == 0.2

    asyncio.run(main())
