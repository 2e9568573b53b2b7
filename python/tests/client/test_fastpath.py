"""The sync bus's fast path for single requests (drivers/fastpath.py, docs/performance.md).

Every scenario runs twice, with the fast path on and with NURIMC_NO_FAST_PATH=1, and must give
the same result, the same bytes written and the same bus state (stats, answers owed, last
answers seen): the fast path takes only the plain answer and hands everything else to the
procedure where it would be."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from nurimc import Bus, Group
from nurimc.core.clock import RealClock, VirtualClock
from nurimc.drivers import fastpath
from nurimc.drivers.perform import LATE_READ
from nurimc.drivers.perform import run_in_place as real
from nurimc.errors import PortError
from nurimc.protocol import Ping, PositionFeedback, RequestPosition, SpeedFeedback

from .fakes import ScriptedTransport
from .simfixtures import sim_bus

ANSWER = PositionFeedback(3, 0, 18000, 15, 2)
OTHER = PositionFeedback(4, 1, 9000, 0, 0)
STALE = PositionFeedback(3, 1, 100, 0, 0)  # an answer that came after its call gave up


class ChunkedTransport(ScriptedTransport):
    """Answers from a list, one per write (then nothing), read at most `chunk` bytes at a time."""

    def __init__(self, answers: list[bytes], chunk: int = 64, waiting: bytes = b"", lost_at: int = 0) -> None:
        script = iter(answers)
        super().__init__(lambda data: next(script, b""))
        self.chunk = chunk
        self.inbox += waiting
        self.reads = 0
        self.lost_at = lost_at  # this read (from 1) fails as an unplugged adapter would

    def read(self, max_bytes: int, timeout: float) -> bytes:
        self.reads += 1
        if self.reads == self.lost_at:
            raise PortError("the port closed (adapter unplugged?)")
        return super().read(min(max_bytes, self.chunk), timeout)


def broken(frame: bytes) -> bytes:
    return frame[:-1] + bytes([frame[-1] ^ 0x55])


SCENARIOS: dict[str, Callable[[], ChunkedTransport]] = {
    "plain": lambda: ChunkedTransport([ANSWER.encode()] * 3),
    "in chunks": lambda: ChunkedTransport([ANSWER.encode()] * 3, chunk=5),
    "byte by byte": lambda: ChunkedTransport([ANSWER.encode()] * 3, chunk=1),
    "no answer": lambda: ChunkedTransport([]),
    "broken, then good": lambda: ChunkedTransport([broken(ANSWER.encode()), ANSWER.encode(), ANSWER.encode()]),
    "echo first": lambda: ChunkedTransport([RequestPosition(3).encode() + ANSWER.encode()] * 3),
    "another ID answers": lambda: ChunkedTransport([OTHER.encode()] * 3),
    "another ID, then ours": lambda: ChunkedTransport([OTHER.encode() + ANSWER.encode()] * 3),
    "a ping instead": lambda: ChunkedTransport([Ping(3).encode()] * 3),
    # as long as the answer, its header and ID right: only the mode byte tells it is not the answer
    "speed feedback instead": lambda: ChunkedTransport([SpeedFeedback(3, 0, 15, 1800, 2).encode()] * 3),
    "stale answer waiting": lambda: ChunkedTransport([ANSWER.encode()] * 3, waiting=STALE.encode()),
    "noise waiting": lambda: ChunkedTransport([ANSWER.encode()] * 3, waiting=b"\x01\xff\x02"),
    "answer and noise": lambda: ChunkedTransport([ANSWER.encode() + b"\xff"] * 3),
    "short answer": lambda: ChunkedTransport([ANSWER.encode()[:7]] * 3),
    # the request stays owed: the next call fences before asking again
    "port fails in the read": lambda: ChunkedTransport([ANSWER.encode()] * 4, lost_at=1),
}


def state(bus: Bus) -> dict[str, Any]:
    core = bus.core
    return {
        "stats": core.stats.as_dict(),
        "owed": {i: [(o.kind, o.order) for o in owed] for i, owed in core._owed.items()},
        "last": {i: seen[0] for i, seen in core._last_seen.items()},
        "sent": core._sent_count,
    }


def outcome(call: Callable[[], object]) -> object:
    try:
        return call()
    except Exception as err:  # the error is part of what both paths must agree on
        return (type(err).__name__, str(err))


def run(scenario: str, fast: bool, monkeypatch: pytest.MonkeyPatch) -> tuple[object, ...]:
    monkeypatch.setenv(fastpath.NO_FAST_PATH, "" if fast else "1")
    transport = SCENARIOS[scenario]()
    bus = Bus(transport)
    motor = bus.motor(3)
    results = [outcome(motor.read_state), outcome(motor.read_state), outcome(lambda: bus.request(RequestPosition(3)))]
    return results, transport.written, state(bus)


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_the_fast_path_and_the_procedure_agree(scenario: str, monkeypatch: pytest.MonkeyPatch) -> None:
    fast = run(scenario, True, monkeypatch)
    assert fast == run(scenario, False, monkeypatch)
    if scenario == "plain":  # the scenario does what it says: both reads are answered
        assert fast[0][0] == fast[0][1] and fast[2]["stats"]["answers"] == 3  # type: ignore[index]
    if scenario == "no answer":
        # three attempts, then the next calls fence first (answers owed): the procedure's rules ran
        assert fast[0][0][0] == "NoAnswer" and fast[1][:3] == [RequestPosition(3).encode()] * 3  # type: ignore[index]
        assert fast[2]["stats"]["fences"] > 0  # type: ignore[index]
    if scenario == "port fails in the read":
        assert fast[0][0][0] == "PortError" and fast[2]["stats"]["fences"] == 1  # type: ignore[index]


def test_the_plain_answer_runs_no_procedure(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(fastpath.NO_FAST_PATH, raising=False)

    def no_procedure(*args: object) -> None:
        raise AssertionError("the plain answer went through the procedure")

    monkeypatch.setattr(fastpath, "run_in_place", no_procedure)
    bus = Bus(ChunkedTransport([ANSWER.encode()] * 2))
    assert bus.motor(3).read_state().device_position == 180.0
    assert bus.request(RequestPosition(3)) == ANSWER


def test_a_listener_or_a_pending_busy_window_takes_the_procedure(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(fastpath.NO_FAST_PATH, raising=False)
    taken: list[object] = []
    monkeypatch.setattr(fastpath, "run_in_place", lambda *a: taken.append(a[0]) or real(*a))  # type: ignore[func-returns-value]

    class Tracer:
        def __init__(self) -> None:
            self.seen: list[tuple[str, bytes]] = []

        def record(self, direction: str, data: bytes) -> None:
            self.seen.append((direction, data))

        def close(self) -> None:
            pass

    tracer = Tracer()
    bus = Bus(ChunkedTransport([ANSWER.encode()]), tracer=tracer)
    bus.motor(3).read_state()
    assert tracer.seen == [("tx", RequestPosition(3).encode()), ("rx", ANSWER.encode())]  # every byte seen
    bus = Bus(ChunkedTransport([ANSWER.encode()]))
    bus.core._waits_pending = 1e18  # an EEPROM write's window not yet waited out
    bus.core._busy_until[3] = 0.0
    bus.motor(3).read_state()
    assert len(taken) == 1


@pytest.mark.parametrize("fast", [True, False], ids=["fast", "procedure"])
def test_group_reads_and_settings_on_the_simulator(fast: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(fastpath.NO_FAST_PATH, "" if fast else "1")
    sim, bus = sim_bus([1, 2, 3], baud=115200)
    try:
        group = Group(bus, [1, 2, 9, 3])  # ID 9 is not on the bus: its error in its place
        states = group.read_states()
        assert list(states) == [1, 2, 9, 3]
        assert type(states[9]).__name__ == "NoAnswer"
        assert all(states[i].id == i for i in (1, 2, 3))  # type: ignore[union-attr]
        assert bus.motor(2).get("ratio") == 1.0
        assert bus.core.stats.answers == 4 and bus.core.stats.no_answer == 1
    finally:
        bus.close()
        sim.close()


class DozingClock(RealClock):
    """The real clock, but the host dozes off for a second right after each write has returned
    (a loaded host): the second reading after a write (the write's end is the first) is late."""

    def __init__(self) -> None:
        self.offset = 0.0
        self.readings_to_doze = 0

    def now(self) -> float:
        if self.readings_to_doze:
            self.readings_to_doze -= 1
            if not self.readings_to_doze:
                self.offset += 1.0
        return super().now() + self.offset


@pytest.mark.parametrize("fast", [True, False], ids=["fast", "procedure"])
def test_a_host_waking_past_the_deadline_takes_the_answer(fast: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(fastpath.NO_FAST_PATH, "" if fast else "1")
    clock = DozingClock()
    transport = ChunkedTransport([ANSWER.encode()] * 2)
    respond = transport.respond
    reads: list[float] = []
    read = transport.read

    def dozing(data: bytes) -> bytes:
        clock.readings_to_doze = 2
        return respond(data)

    def late_read(max_bytes: int, timeout: float) -> bytes:
        reads.append(timeout)
        return read(max_bytes, timeout)

    transport.respond = dozing
    transport.read = late_read  # type: ignore[method-assign]
    bus = Bus(transport, clock=clock)
    assert bus.motor(3).read_state().device_position == 180.0  # the late read takes what came
    assert bus.request(RequestPosition(3)) == ANSWER
    assert reads == [LATE_READ, LATE_READ]  # each read started past its deadline
    assert (bus.core.stats.answers, bus.core.stats.retries, bus.core._owed) == (2, 0, {})


@pytest.mark.parametrize("fast", [True, False], ids=["fast", "procedure"])
def test_group_reads_give_each_reading_the_time_it_was_read(fast: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    # the multi-turn tracking needs the time between readings (a gap too long is marked uncertain)
    monkeypatch.setenv(fastpath.NO_FAST_PATH, "" if fast else "1")
    clock = VirtualClock()
    answers = {i: PositionFeedback(i, 0, 1000 * i, 0, 0).encode() for i in (1, 2)}
    bus = Bus(ScriptedTransport(lambda data: answers[data[2]]), clock=clock)
    group = Group(bus, [1, 2])
    assert [s.device_position for s in group.read_states().values()] == [10.0, 20.0]  # type: ignore[union-attr]
    assert [m.procedures.tracker._at for m in group.motors] == [clock.now(), clock.now()]
