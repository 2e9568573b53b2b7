"""Shared IDs: find them, never make them (issue 38, issue 39 item 3).

Two new controllers both come as ID 0 at 9,600 bps. On one bus they answer every request to ID 0
at the same moment and their answers collide: bytes that are no frame. A write to that ID reaches
both (a `set id 1` would give both ID 1: still shared), so nothing is written to a shared ID;
the way out is physical: connect one at a time, then give each an ID.

- `who_answers(core, id)`: "none", "one" or "shared" (garbled answers twice in a row, each asked
  alone: one garbled answer can be noise; two, both garbled, are answers on top of each other,
  the rule discovery uses).
- `ping_alone(core, id)`: the same with the frames config.answers sends (one ping, one retry).
- `check_not_shared(core, id)`: raises IdShared (with the advice) if the ID is shared.
- `check_free(core, id, rate)`: raises IdInUse if the ID already answers at `rate` (asked there;
  the bus goes back to its rate afterwards): before a change that would put a controller on it.

These are procedures (they yield actions) like nurimc.procedures.config, which calls them before `set id`,
`set baud` and factory reset.
"""

from __future__ import annotations

from typing import Literal

from ..core.actions import Procedure
from ..core.buscore import BusCore
from ..errors import CorruptedAnswer, IdInUse, NoAnswer, UnexpectedAnswer
from ..protocol import RequestPing

Answering = Literal["none", "one", "shared"]

#: What to do about a shared ID: the one way that works (docs/troubleshooting.md, Two controllers
#: share an ID).
RECOVERY = "connect one at a time, then give each an ID (nurimc --id {id} set id N, a different N for each)"


class IdShared(IdInUse):
    """Several controllers answer at one ID: their answers collide. Nothing was written."""


def shared_message(device_id: int, baud: int) -> str:
    return f"two or more controllers share ID {device_id} at {baud} bps: " + RECOVERY.format(id=device_id)


def who_answers(core: BusCore, device_id: int) -> Procedure[Answering]:
    """Ask a ping alone, twice if the first answer is garbled: none, one, or shared."""
    garbled = 0
    for _ in range(2):
        try:
            yield from core.ask(RequestPing(device_id), retries=0)
            return "one"
        except UnexpectedAnswer:
            return "one"  # a frame from that ID: one controller (of some line) answers
        except CorruptedAnswer:
            garbled += 1
        except NoAnswer:
            return "shared" if garbled else "none"
    return "shared"


def ping_alone(core: BusCore, device_id: int) -> Procedure[Answering]:
    """One ping with one retry (what config.answers sends): none, one, or shared when the answers
    came garbled (core.ask raises CorruptedAnswer when its last attempt was garbled bytes)."""
    try:
        yield from core.ask(RequestPing(device_id), retries=1)
    except UnexpectedAnswer:
        return "one"
    except CorruptedAnswer:
        return "shared"
    except NoAnswer:
        return "none"
    return "one"


def check_not_shared(core: BusCore, device_id: int) -> Procedure[None]:
    """Raise IdShared (nothing sent but pings) when several controllers answer at `device_id`."""
    if (yield from who_answers(core, device_id)) == "shared":
        raise IdShared(shared_message(device_id, core.baudrate) + "; nothing was written")


def check_free(core: BusCore, device_id: int, rate: int, why: str) -> Procedure[None]:
    """Raise IdInUse when `device_id` already answers at `rate` (one or several controllers).
    Asked at `rate`; the bus is back at its own rate afterwards, whatever happens."""
    old = core.baudrate
    try:
        if rate != old:
            yield from core.set_baud(rate)
        answering = yield from who_answers(core, device_id)
    except GeneratorExit:  # closed: no I/O any more
        raise
    except BaseException as failure:  # the host goes back to its rate (docs/drivers.md)
        if core.baudrate != old:
            yield from core.return_to_baud(old, failure)
        raise
    if core.baudrate != old:
        yield from core.set_baud(old)
    if answering != "none":
        raise IdInUse(f"ID {device_id} already answers at {rate} bps: {why}")
