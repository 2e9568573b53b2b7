"""Find every controller on the bus across the 18 rates and 255 IDs, at the wire's pace.

For each rate: one broadcast ping (every controller at that rate answers after its response
time). Clean answers name the controllers directly; silence means nobody listens at that
rate. Only if bytes came back garbled (several controllers answering together, as controllers
that share a rate and the default response time do) are the IDs walked one by one at that
rate. The broadcast has measured how soon answers begin on this bus (request on the wire,
response time, adapter), so each request of the walk (a firmware request: as short as a
ping, and its answer says the firmware) waits only until an answer would have begun, and a
whole frame once one has: the walk runs at the wire floor (one request plus the shortest wait
in which an answer would have started, per ID; benchmarks/wire_bench.py). A late answer
still names its ID, so it is found wherever it turns up; garbled bytes in the walk name
nobody, so the IDs that may have sent them are asked alone before anything is reported
(_confirm). Rates are tried most likely first. Discovery never writes a setting: only pings
and firmware requests go out.
The vendor's tool pings every ID at every rate, 60 ms per try: 20-30 minutes.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from ..core.actions import Note, Now, Procedure
from ..core.buscore import BusCore
from ..core.timing import MAX_RESPONSE_TIME
from ..errors import CorruptedAnswer, FixedRate, NoAnswer, RateRefused, UnexpectedAnswer
from ..protocol import BAUD_RATES, Firmware, RequestFirmware, RequestPing
from ..protocol.host import DISCOVERY_RATE_ORDER
from .products import detect_line

# Most likely first: the default, then the usual fast rates, then the rest (spec/host.json).
RATE_ORDER = DISCOVERY_RATE_ORDER
#: response time assumed while walking IDs without a broadcast to measure it (settings up to 50 x 100 us)
WALK_RESPONSE_TIME = 0.005
PING_LENGTH = 6  # bytes of a ping request and of its answer


@dataclass(frozen=True, slots=True)
class Found:
    id: int
    baudrate: int
    firmware: int | None
    collision: bool = False  # several controllers answer at this ID and rate
    line: str = "unknown"  # product line by the vendor's rule (nurimc.procedures.products); "unknown" if none matched


@dataclass(frozen=True, slots=True)
class Progress:
    rate: int
    rate_index: int  # 0-based, of rates_total
    rates_total: int
    walking_id: int | None  # the ID being pinged while walking, else None
    found: tuple[Found, ...] = field(default=())


@dataclass(frozen=True, slots=True)
class FixedLink:
    """The link runs at one rate (a TCP gateway): the search is made once, at `rate` (note)."""

    rate: int
    reason: str


@dataclass(frozen=True, slots=True)
class RateSkipped:
    """A rate the port refused (note, then the scan goes on): `reason` names rate and adapter."""

    rate: int
    reason: str


def walk_wait(core: BusCore, span: float | None) -> float:
    """Seconds after a walk ping's write by which its answer would have begun.

    `span`: from the broadcast ping's write to the last byte heard after it: every answer
    began at least one answer-frame earlier, so answers begin by span - frame; two characters
    and the adapter's latency (its jitter) are the slack. Without a measurement: the wire
    times, an assumed response time and the adapter latency both ways."""
    rate, timing = core.baudrate, core.timing
    char = timing.wire_time(1, rate)
    if span is None:
        return timing.wire_time(PING_LENGTH, rate) + WALK_RESPONSE_TIME + 2 * timing.latency + timing.margin + char
    return max(span - timing.wire_time(PING_LENGTH, rate), 0.0) + 2 * char + timing.latency


def _owing(core: BusCore, probed: list[int], heard: set[int]) -> Procedure[list[int]]:
    """The IDs walked before whose answers may still be on the way (docs/protocol.md, Stale
    answers: owed until deadline + late), latest first: garbled bytes are theirs or the walked ID's."""
    core.forget_expired((yield Now()))
    return [i for i in reversed(probed) if i not in heard and core.owes(i, Firmware)]


def _confirm(
    core: BusCore, rate: int, walked: int, earlier: list[int], heard: set[int], found: list[Found]
) -> Procedure[None]:
    """Garbled bytes came while `walked` was probed: answers on top of each other. They are the
    walked ID's (several controllers share it) or late answers of IDs walked before it that
    overlapped on the wire (a TCP serial server's jitter can hold a request back until the next
    one: both reach the bus together). Each suspect is asked alone, with the full deadline, once
    the answers still owed are settled by the stale-answer rule (core.ask's fences): an answer
    names it, garbled bytes again make it a collision, silence clears it. The walked ID is asked
    first; a collision there explains the bytes, and the others are not asked."""
    yield from core.wait_out([walked, *earlier], Firmware)  # one wait for all: no fence per ID
    for device_id in [walked, *earlier]:
        if device_id in heard:
            continue
        try:
            answer = yield from core.ask(RequestFirmware(device_id))
        except CorruptedAnswer:
            heard.add(device_id)
            found.append(Found(device_id, rate, None, collision=True))
            if device_id == walked:
                return
        except (NoAnswer, UnexpectedAnswer):
            continue
        else:
            heard.add(device_id)
            found.append(Found(device_id, rate, answer.fields()["version"]))


def discover(
    core: BusCore,
    rates: Iterable[int] | None = None,
    ids: Iterable[int] | None = None,
    broadcast: bool = True,
    lines: bool = True,
) -> Procedure[list[Found]]:
    """Find controllers. Progress is reported as Note(Progress(...)) (and Note(RateSkipped(...))
    for a rate the port refuses). On a link at one rate (a `socket://` gateway: FixedRate) the
    search is made once, at the link's rate, said by Note(FixedLink(...)): every controller is
    reported once, at the rate that is real. Leaves the bus at its old rate."""
    rate_list = [r for r in RATE_ORDER if r in set(rates or BAUD_RATES)]
    id_list = list(range(255) if ids is None else ids)
    original = core.baudrate
    found: list[Found] = []
    fixed: int | None = None  # a link at one rate (FixedRate): searched once, at that rate
    try:
        position = 0
        while position < len(rate_list):
            rate, index = rate_list[position], position
            try:
                yield from core.set_baud(rate)
            except FixedRate as link:
                if fixed is not None:  # cannot happen: the plan holds only the link's rate by now
                    raise
                fixed = link.rate  # said once; what is left of the plan is the link's rate alone
                yield Note(FixedLink(link.rate, str(link)))
                done = rate_list[:position]
                rate_list = done + ([] if link.rate in done else [link.rate])
                continue
            except RateRefused as refused:
                yield Note(RateSkipped(rate, str(refused)))
                position += 1
                continue
            position += 1
            yield Note(Progress(rate, index, len(rate_list), None, tuple(found)))
            garbled, heard, span = True, set[int](), None
            if broadcast and ids is None:
                window = core.timing.answer_deadline(PING_LENGTH, PING_LENGTH, rate, MAX_RESPONSE_TIME)
                # silence until an answer would have begun (any response time) means nobody is here
                begun = window - core.timing.wire_time(PING_LENGTH - 1, rate)
                answers, dropped = yield from core.broadcast_ask(RequestPing, window, start_within=begun)
                heard = {a.id for a in answers}
                garbled, span = dropped > 0, core.broadcast_span
            first = len(found)  # this rate's finds start here
            for device_id in sorted(heard):
                found.append(Found(device_id, rate, None))
            if not garbled:
                continue
            start_within = walk_wait(core, span)
            probed: list[int] = []
            garbles: list[tuple[int, list[int]]] = []  # (walked ID, earlier IDs still owing an answer)
            for device_id in id_list:
                if device_id in heard:
                    continue
                yield Note(Progress(rate, index, len(rate_list), device_id, tuple(found)))
                # a firmware request: as short as a ping, and its answer names the firmware too
                answers, collided = yield from core.probe(RequestFirmware(device_id), start_within)
                for answer in answers:
                    if answer.id not in heard:
                        heard.add(answer.id)
                        found.append(Found(answer.id, rate, answer.fields()["version"]))
                if collided:
                    garbles.append((device_id, (yield from _owing(core, probed, heard))))
                probed.append(device_id)
            for device_id, earlier in garbles:
                yield from _confirm(core, rate, device_id, earlier, heard, found)
            found[first:] = sorted(found[first:], key=lambda f: f.id)
        result = []
        for f in found:  # firmware tells the user what answered; also confirms a find of the broadcast
            # a collision was asked alone already (_confirm): it garbled again
            if not f.collision and (f.firmware is None or lines):
                yield from core.set_baud(f.baudrate)
            if f.firmware is None and not f.collision:
                try:
                    answer = yield from core.ask(RequestFirmware(f.id))
                    f = Found(f.id, f.baudrate, answer.fields()["version"], f.collision)
                except (NoAnswer, UnexpectedAnswer):
                    pass
            if lines and not f.collision:  # each controller's product line (nurimc.procedures.products)
                identified = yield from detect_line(core, f.id)
                f = Found(f.id, f.baudrate, f.firmware, f.collision, identified.line)
            result.append(f)
    except GeneratorExit:  # closed by its driver: no I/O possible any more (finally still runs)
        raise
    except BaseException as failure:  # an I/O error, a timeout or a cancellation thrown in (docs/drivers.md)
        yield from core.return_to_baud(original, failure)
        raise
    yield from core.set_baud(original)
    return result
