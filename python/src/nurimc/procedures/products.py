"""Which product line a controller speaks, by the vendor's rule (spec/lines.json, "detection").

The vendor's Supporter (product-lines.md §6) asks each found controller, in order: `AB`
(MC's control direction) -> an answer makes it **MC**; else `AA` (RSAVW's echo) -> **RSAVW**;
else `A8` (RSA's position mode) -> **RSA**; else it calls it **SM** by elimination. We take
an answer only in the asked line's own layout (mode + 0x30 with that line's size), not any
of the modes the Supporter also accepts, and we confirm the SM instead of assuming it: an SM
answers `A4` (its reduction ratio) with a 4-byte `D4`, which no MC, RSA or RSAVW sends (theirs
is speed gains, 6 bytes). A controller that answers none of the four is `unknown`.

Limits (the rule's, documented in docs/protocol.md, Product lines): SA answers like RSA and is
named RSA; BLMC-H answers like MC and is named MC; the SM's table for commands 01-05 cannot be
known from its answers (both vendor tables agree on every request), so a detected SM is `sm`:
the agreed messages only, until the user says `sm-cs` or `sm-readme`.

Sans-I/O: `detect_line` is a procedure on a BusCore, like discovery.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.actions import Procedure
from ..core.buscore import BusCore
from ..errors import NoAnswer, UnexpectedAnswer
from ..protocol import Request, line

#: the rule in order: (line named by an answer, the request that line answers and others do not)
RULE: tuple[tuple[str, str], ...] = (
    ("mc", "request_direction"),  # AB -> DB
    ("rsavw", "request_echo"),  # AA -> DA
    ("rsa", "request_position_mode"),  # A8 -> D8
    ("sm", "request_ratio"),  # A4 -> D4 of 4 bytes (our confirmation of the vendor's "else SM")
)
UNKNOWN = "unknown"
#: what each detected line is, for people (the rule's limits included)
DESCRIPTIONS = {
    "mc": "MC or BLMC-H",
    "rsavw": "RSAVW",
    "rsa": "RSA or SA",
    "sm": "SM: table unknown; --product sm-cs or sm-readme to drive it",
    UNKNOWN: "answers none of the line questions",
}


@dataclass(frozen=True, slots=True)
class Identified:
    """A controller's line by the rule, and the request that decided it (None: none did)."""

    id: int
    line: str
    asked: str | None


def probe(key: str, device_id: int) -> Request:
    """The request of step `key` of the rule, in its line's own table."""
    request = line(key).make(dict(RULE)[key], device_id)
    assert isinstance(request, Request)
    return request


def detect_line(core: BusCore, device_id: int) -> Procedure[Identified]:
    """Ask the rule's questions in order; the first answered names the line. Records the line
    as the ID's product on the core (for its busy window and for bus.motor(id)) unless the
    caller declared a product of that line already (e.g. blmc-h for an MC answer)."""
    known = core.products.pop(device_id, None)  # the probes are of every line: none is refused
    for key, _ in RULE:
        try:
            yield from core.ask(probe(key, device_id))
        except (NoAnswer, UnexpectedAnswer):
            continue
        except BaseException:
            if known is not None:
                core.products[device_id] = known
            raise
        keep = known is not None and line_of_product(known) == key  # e.g. blmc-h, declared, answers as MC
        core.products[device_id] = known if keep and known is not None else key
        return Identified(device_id, key, dict(RULE)[key])
    if known is not None:
        core.products[device_id] = known
    return Identified(device_id, UNKNOWN, None)


def line_of_product(product: str) -> str:
    from ..protocol._lines import PRODUCT_LINES

    return PRODUCT_LINES.get(product, product)
