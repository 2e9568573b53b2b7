"""The shared stale-answer cases (spec/vectors/stale-answers.json) against BusCore.

Each case is a scripted exchange on a virtual clock: the procedures are stepped by hand (as
stepping.Stepper does) and the wire answers each frame the client sends as the case says. The
TypeScript client runs the same file (ts/test/stale-conformance.test.ts); docs/protocol.md,
Stale answers, is the rule both follow.
"""

from __future__ import annotations

import heapq
import json
from itertools import count
from typing import Any

import pytest

from nurimc.core.actions import Discard, Note, Now, Procedure, Receive, Send, Sent, Wait, WaitUntil
from nurimc.core.buscore import BusCore
from nurimc.core.timing import Timing
from nurimc.procedures.group import read_states_broadcast
from nurimc.procedures.motor import MotorProcedures, MotorState
from nurimc.protocol import Message, StreamParser, answer_class, make, make_request, message_class

from ..conftest import ROOT

SHARED = json.loads((ROOT / "spec" / "vectors" / "stale-answers.json").read_text(encoding="utf-8"))
TIMING = SHARED["timing"]


def parse_one(frame: bytes) -> Message:
    parser = StreamParser()
    messages = [*parser.feed(frame), *parser.finish()]
    assert len(messages) == 1, frame.hex()
    return messages[0]


def build(name: str, device_id: int, fields: dict[str, Any]) -> bytes:
    names = message_class(name).SPEC.field_names
    return make(name, device_id, **{f: fields.get(f, 0) for f in names}).encode()


class ScriptedWire:
    """A virtual clock and the bytes on their way to the host, for stepping procedures."""

    def __init__(self, core: BusCore) -> None:
        self.core = core
        self.clock = 100.0
        self.arrivals: list[tuple[float, int, bytes]] = []  # (time, order, bytes), a heap
        self.order = count()
        self.sent: list[Message] = []
        self.script: list[dict[str, Any]] = []

    def arrive(self, at: float, data: bytes) -> None:
        heapq.heappush(self.arrivals, (at, next(self.order), data))

    def deadline(self, request: Message, frame_len: int) -> float:
        answer = answer_class(type(request))
        return self.core.timing.answer_deadline(
            frame_len, answer.SPEC.size + 4, self.core.baudrate, self.core.response_times.get(request.id)
        )

    def written(self, frame: bytes, end: float) -> None:
        request = parse_one(frame)
        index = len(self.sent)
        self.sent.append(request)
        for entry in self.script:
            if entry["frame"] != index:
                continue
            at = entry["at"]
            when = (
                end
                + at.get("ms", 0) / 1000
                + (at["D"] * self.deadline(request, len(frame)) if "D" in at else 0)
                + at.get("L", 0) * self.core.late_answer
                + at.get("chars", 0) * self.core.timing.wire_time(1, self.core.baudrate)
            )
            if "message" in entry:
                spec = dict(entry["message"])
                name, device_id = spec.pop("name"), spec.pop("id", request.id)
                data = build(name, device_id, spec)
            else:
                data = build(answer_class(type(request)).SPEC.name, request.id, entry["answer"])
            part = entry.get("part")
            if part is not None:
                data = data[part[0] : part[1] if len(part) > 1 else None]
            self.arrive(when, data)

    def run(self, procedure: Procedure[Any], script: list[dict[str, Any]]) -> Any:
        """Drive the procedure to its end; returns its value (or raises its error)."""
        self.sent, self.script = [], script
        result: Any = None
        while True:
            action = procedure.send(result)
            if type(action) is Now:
                result = self.clock
            elif type(action) is Wait:
                self.clock += action.seconds
                result = None
            elif type(action) is WaitUntil:
                self.clock = max(self.clock, action.when)
                result = self.clock
            elif type(action) is Note:
                result = None
            elif type(action) is Discard:
                result = b""
                while self.arrivals and self.arrivals[0][0] <= self.clock:
                    result += heapq.heappop(self.arrivals)[2]
            elif type(action) is Send:
                # the write takes no time here (the TypeScript runner's port resolves at once too)
                self.written(action.data, self.clock)
                result = Sent(self.clock, self.clock)
            elif type(action) is Receive:
                if self.arrivals and self.arrivals[0][0] <= action.until:
                    at, order, data = heapq.heappop(self.arrivals)
                    self.clock = max(self.clock, at)
                    result, rest = data[: action.max_bytes], data[action.max_bytes :]
                    if rest:
                        heapq.heappush(self.arrivals, (at, order, rest))
                else:
                    self.clock = max(self.clock, action.until)
                    result = b""
            else:
                raise AssertionError(f"unexpected action {action!r}")

    def call(self, procedure: Procedure[Any], script: list[dict[str, Any]]) -> Any:
        try:
            self.run(procedure, script)
        except StopIteration as done:
            return done.value
        raise AssertionError("unreachable")


def outcome(result: Message | Exception) -> dict[str, Any]:
    if isinstance(result, Exception):
        return {"error": type(result).__name__}
    if result.name == "position_feedback":
        return {"position": result.fields()["position"]}
    return {"name": result.name}


def state_outcome(state: MotorState | Exception) -> dict[str, Any]:
    """A broadcast read's entry, as the raw position its answer carried (0.01 degree units)."""
    if isinstance(state, Exception):
        return {"error": type(state).__name__}
    return {"position": round(abs(state.device_position) * 100)}


@pytest.mark.parametrize("case", SHARED["cases"], ids=[c["name"] for c in SHARED["cases"]])
def test_shared_stale_case(case: dict[str, Any]) -> None:
    core = BusCore(
        baudrate=TIMING["baud"],
        timing=Timing(
            latency=TIMING["latency_ms"] / 1000,
            margin=TIMING["margin_ms"] / 1000,
            assumed_response_time=TIMING["response_time_us"] / 1e6,
        ),
        retries=case["retries"],
    )
    wire = ScriptedWire(core)
    for number, step in enumerate(case["steps"]):
        started = wire.clock
        got: dict[str, Any]
        if "ask" in step:
            ask = step["ask"]
            try:
                got = outcome(wire.call(core.ask(make_request(ask["request"], ask["id"])), step["wire"]))
            except Exception as error:  # a typed error is a result here: the case says which
                got = outcome(error)
        else:
            ask = step["ask_all"]
            motors = [MotorProcedures(core, i) for i in ask["ids"]]
            states = wire.call(read_states_broadcast(motors, ask["slot"]), step["wire"])
            got = {str(i): state_outcome(s) for i, s in states.items()}
        where = f"step {number}"
        assert [f"{m.name} {m.id}" for m in wire.sent] == step["sends"], where
        assert got == step["expect"], where
        if "min_elapsed" in step:
            request = make_request(step["ask"]["request"], step["ask"]["id"])
            least = step["min_elapsed"].get("D", 0) * wire.deadline(request, len(request.encode()))
            least += step["min_elapsed"].get("L", 0) * core.late_answer
            assert wire.clock - started >= least, where
        if "max_elapsed" in step:
            assert wire.clock - started <= step["max_elapsed"]["ms"] / 1000, where
        core.forget_expired(wire.clock)
        for device_id, owed in step.get("owed_after", {}).items():
            assert len(core._owed.get(int(device_id), [])) == owed, f"{where}: ID {device_id} owes"
    stats = core.stats.as_dict()
    assert {k: stats[k] for k in case["stats"]} == case["stats"]
