"""Find every controller on the bus across the 18 rates and 255 IDs, in seconds.

For each rate: one broadcast ping (every controller at that rate answers after its response
time). Clean answers name the controllers directly. Only if bytes came back garbled (several
controllers answering together, e.g. all at the default ID 0 or the default response time)
are the IDs walked one by one at that rate, each ping timing out as soon as the wire says no
answer can have started. Rates are tried most likely first. The vendor's tool pings every ID
at every rate, 60 ms per try: 20-30 minutes.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from .client.actions import Note, Procedure
from .client.core import BusCore
from .client.timing import MAX_RESPONSE_TIME, Timing
from .errors import CorruptedAnswer, NoAnswer, UnexpectedAnswer
from .products import detect_line
from .protocol import BAUD_RATES, RequestFirmware, RequestPing

# Most likely first: the default, then the usual fast rates, then the rest.
RATE_ORDER = (
    9600,
    115200,
    1000000,
    57600,
    19200,
    38400,
    500000,
    250000,
    230400,
    76800,
    28800,
    14400,
    4800,
    2400,
    1200,
    600,
    300,
    110,
)
WALK_RESPONSE_TIME = 0.005  # response time assumed while walking IDs (settings up to 50 x 100 us)


@dataclass(frozen=True, slots=True)
class Found:
    id: int
    baudrate: int
    firmware: int | None
    collision: bool = False  # several controllers answer at this ID and rate
    line: str = "unknown"  # product line by the vendor's rule (nurimc.products); "unknown" if none matched


@dataclass(frozen=True, slots=True)
class Progress:
    rate: int
    rate_index: int  # 0-based, of rates_total
    rates_total: int
    walking_id: int | None  # the ID being pinged while walking, else None
    found: tuple[Found, ...] = field(default=())


def discover(
    core: BusCore,
    rates: Iterable[int] | None = None,
    ids: Iterable[int] | None = None,
    broadcast: bool = True,
    lines: bool = True,
) -> Procedure[list[Found]]:
    """Find controllers. Progress is reported as Note(Progress(...)). Leaves the bus at its old rate."""
    rate_list = [r for r in RATE_ORDER if r in set(rates or BAUD_RATES)]
    id_list = list(range(255) if ids is None else ids)
    original, original_timing = core.baudrate, core.timing
    found: list[Found] = []
    try:
        for index, rate in enumerate(rate_list):
            yield from core.set_baud(rate)
            yield Note(Progress(rate, index, len(rate_list), None, tuple(found)))
            garbled, heard = True, set[int]()
            if broadcast and ids is None:
                window = core.timing.answer_deadline(6, 6, rate, MAX_RESPONSE_TIME)
                answers, dropped = yield from core.broadcast_ask(RequestPing, window)
                heard = {a.id for a in answers}
                garbled = dropped > 0
            for device_id in sorted(heard):
                found.append(Found(device_id, rate, None))
            if not garbled:
                continue
            core.timing = Timing(original_timing.latency, original_timing.margin, WALK_RESPONSE_TIME)
            for device_id in id_list:
                if device_id in heard:
                    continue
                yield Note(Progress(rate, index, len(rate_list), device_id, tuple(found)))
                try:
                    yield from core.ask(RequestPing(device_id), retries=0)
                    found.append(Found(device_id, rate, None))
                except CorruptedAnswer:
                    found.append(Found(device_id, rate, None, collision=True))
                except (NoAnswer, UnexpectedAnswer):
                    pass
            core.timing = original_timing
        result = []
        for f in found:  # firmware tells the user what answered; also confirms the find
            yield from core.set_baud(f.baudrate)
            try:
                answer = yield from core.ask(RequestFirmware(f.id))
                f = Found(f.id, f.baudrate, answer.fields()["version"], f.collision)
            except (NoAnswer, UnexpectedAnswer):
                pass
            if lines and not f.collision:  # each controller's product line (nurimc.products)
                identified = yield from detect_line(core, f.id)
                f = Found(f.id, f.baudrate, f.firmware, f.collision, identified.line)
            result.append(f)
    except GeneratorExit:  # closed by its driver: no I/O possible any more (finally still runs)
        raise
    except BaseException as failure:  # an I/O error, a timeout or a cancellation thrown in (docs/drivers.md)
        core.timing = original_timing
        yield from core.return_to_baud(original, failure)
        raise
    finally:
        core.timing = original_timing
    yield from core.set_baud(original)
    return result
