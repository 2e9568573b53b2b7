"""The sync bus's fast path for the common request (docs/performance.md, issue 33).

`BusCore.ask` is a procedure: every action it yields is a generator round trip and a dispatch
in the trampoline (`perform.run_in_place`). For the commonest call, one request whose ID owes
no answer, on a bus with no byte listener, no EEPROM busy window pending and no call timeout,
`ask` does the same calls on the transport and the clock as the trampoline would (the
duplicate-gap wait, the discard, the write, one read up to the answer's length) straight in
Python, and takes the answer when those bytes are exactly it. Anything else (bytes found by
the discard, a read that timed out or came short, a broken, foreign or echoed frame, a host that
woke past the deadline) is handed to `BusCore.attempts` where the procedure would be at that
point, so fences, retries, stale-frame rules and errors stay one piece of code. The effect on
the core's state (stats, answers owed, the last answer seen) is the procedure's.

NURIMC_NO_FAST_PATH=1 in the environment turns it off (every call runs the procedure), for
comparing and for running the request tests both ways.
"""

from __future__ import annotations

import os
from typing import Any
from zlib import adler32

from ..core.actions import Procedure, Send, Sent
from ..core.buscore import BusCore
from ..core.clock import Clock
from ..core.timing import Timing
from ..protocol import Message, Request, StreamParser
from ..protocol._tables import HEADER
from ..protocol.parser import answer_unpacker
from ..transport import Transport
from .perform import Performer, run_in_place

#: the environment variable that turns the fast path off
NO_FAST_PATH = "NURIMC_NO_FAST_PATH"


def enabled() -> bool:
    """The fast path is on unless NURIMC_NO_FAST_PATH is set to something other than 0 or empty."""
    return os.environ.get(NO_FAST_PATH, "") in ("", "0")


class Quick:
    """What the fast path keeps per request: its plan as BusCore keeps it (frame, answer class,
    answer length); the answer's first four bytes (header, ID, size), its mode byte and the
    unpack of its ID and fields (None: the line's table reads the mode otherwise, so the general
    parser decides); and, worked out again only when what they depend on changes, the product
    line check passed (for `product`) and the deadline and duplicate gap (for a rate, a timing
    and a response time)."""

    __slots__ = ("baudrate", "deadline", "gap", "head", "mode", "plan", "product", "response", "timing", "unpack")

    def __init__(self, core: BusCore, request: Request) -> None:
        plan = core._plans.get(request)
        if plan is None:
            plan = core._plan(request)
        self.plan = plan
        spec = plan[1].SPEC
        self.head = HEADER + bytes((request.id, spec.size))
        self.mode = spec.mode
        self.unpack: Any = answer_unpacker(plan[1], request.LINE)
        self.product: object = _UNCHECKED
        self.baudrate = 0
        self.timing: Timing | None = None
        self.response: float | None = None
        self.deadline = self.gap = 0.0


_UNCHECKED = object()
#: the requests' Quick, shared by every bus (what it keeps depends on the request, or is checked)
_QUICK: dict[Request, Quick] = {}
PLANS = 1024
_NEW = tuple.__new__


def ask(core: BusCore, transport: Transport, clock: Clock, request: Request, retries: int | None = None) -> Message:
    """`core.ask(request)` on a sync bus with no listeners and no call timeout (the caller holds
    the bus lock and has checked both). Returns the answer or raises as the procedure does."""
    rid = request.id
    if core._waits_pending or rid in core._owed:  # a busy window to wait out, a fence to send
        return _run(core.ask(request, retries), transport, clock)
    quick = _QUICK.get(request)
    if quick is None:
        if len(_QUICK) >= PLANS:
            _QUICK.clear()
        quick = _QUICK[request] = Quick(core, request)
    product = core.products.get(rid)
    if product != quick.product:  # the product line check (in_its_line), once per product
        core.in_its_line(request)
        quick.product = product
    plan = quick.plan
    frame, cls, answer_len = plan
    baudrate, timing, response = core.baudrate, core.timing, core.response_times.get(rid)
    if baudrate != quick.baudrate or timing is not quick.timing or response != quick.response:
        quick.deadline = timing.answer_deadline(len(frame), answer_len, baudrate, response)
        quick.gap = 2 * timing.wire_time(1, baudrate)
        quick.baudrate, quick.timing, quick.response = baudrate, timing, response
    deadline = quick.deadline
    now = clock.now
    last = core._last_seen.get(rid)
    if last is not None and type(last[0]) is cls:  # the duplicate gap (as ask: WaitUntil(gap))
        gap = last[1] + quick.gap
        if now() < gap:
            delay = gap - now()
            if delay > 0:
                clock.sleep(delay)
    held = transport.discard_input()
    if held:  # bytes came since the last call: settled by the procedure, from its discard on
        attempts = 1 + (core.retries if retries is None else retries)
        procedure = _after_discard(core, request, plan, deadline, attempts, held)
        return _run(procedure, transport, clock)
    started = now()
    transport.write(frame)
    finished = now()
    data: bytes | None = None
    remaining = finished + deadline - now()
    if remaining > 0:  # else: woke late; the procedure's late read takes what came
        try:
            data = transport.read(answer_len, remaining)
        except BaseException:  # as the procedure, which had counted and owed the request by then
            core.stats.requests += 1
            core._owe(rid, cls, finished + deadline + core.late_answer)
            raise
        if data:
            core._now = now()
            message: Message | None = None
            if len(data) == answer_len:
                unpack = quick.unpack
                if unpack is not None:  # the one answer expected, read straight from its bytes
                    if data.startswith(quick.head) and data[5] == quick.mode and not adler32(data[2:]) & 0xFF:
                        message = _NEW(cls, unpack(data, 2))
                else:
                    parser = StreamParser(line=request.LINE)
                    frames = parser.feed(data)
                    if len(frames) == 1 and not parser.pending and type(frames[0]) is cls and frames[0].id == rid:
                        message = frames[0]
            if message is not None:
                # what ask does for this answer: the request counted, owed and resolved
                stats = core.stats
                stats.requests += 1
                stats.answers += 1
                core._sent_count += 1
                core._last_seen[rid] = (message, core._now)
                return message
    attempts = 1 + (core.retries if retries is None else retries)
    procedure = core.attempts(request, plan, deadline, attempts, Sent(started, finished), data)
    return _run(procedure, transport, clock)


def _after_discard(
    core: BusCore,
    request: Request,
    plan: tuple[bytes, type[Message], int],
    deadline: float,
    attempts: int,
    held: bytes,
) -> Procedure[Message]:
    """`ask`'s procedure from the first attempt's discard on, which found `held`."""
    yield from core._discarded(held)
    sent: Sent = yield Send(plan[0])
    return (yield from core.attempts(request, plan, deadline, attempts, sent))


def _run(procedure: Procedure[Message], transport: Transport, clock: Clock) -> Message:
    """Run the rest as `Bus.run` would (no listeners, no note, no call timeout)."""
    return run_in_place(procedure, Performer(transport, (), None, clock), None, transport.read, clock.sleep)
