"""Parsing what the CLI and the sim:// URL accept: controller lists and motors."""

from __future__ import annotations

from ..errors import InputError
from ..inputs import id_list
from ..protocol import BAUD_RATES, PRODUCTS


class OptionError(InputError):
    """A command-line or URL option is malformed; the message says how to write it."""


def check_baud(rate: int) -> int:
    if rate not in BAUD_RATES:
        raise OptionError(
            f"{rate} bps is not a rate these controllers support; use one of " + ", ".join(str(r) for r in BAUD_RATES)
        )
    return rate


def _int(text: str, what: str) -> int:
    try:
        if not text.isascii():  # int() reads Arabic-Indic and fullwidth digits; the rest of the CLI does not
            raise ValueError
        return int(text.strip(), 0)
    except ValueError:
        raise OptionError(f"{what}: {text!r} is not a number") from None


def parse_ids(text: str) -> list[int]:
    """Controller IDs: `1` -> ID 1, `0,1,2` -> those IDs, `0-31` -> IDs 0..31 (mixable: `1,5-7`),
    read by the library's one ID-list reader (nurimc.inputs.id_list); a repeated ID is a second
    controller with that ID (a collision on purpose).

    A single number is one ID, never a count: `sim://?ids=1` is the controller at ID 1."""
    try:
        ids = id_list(text, "--ids")
    except InputError as error:
        raise OptionError(f"{error} (e.g. 1, 0,1,2 or 0-31)") from None
    if len(ids) > 254:
        raise OptionError(f"--ids: {len(ids)} controllers; a bus holds at most 254")
    return ids


def parse_motor(text: str) -> tuple[int, int, str | None]:
    """`ID@RATE[:PRODUCT]` (e.g. 3@57600, 7@57600:rsa) -> (3, 57600, None), (7, 57600, "rsa")."""
    ident, sep, rest = text.partition("@")
    if not sep:
        raise OptionError(f"--motor {text!r}: write ID@RATE or ID@RATE:PRODUCT, e.g. 3@57600 or 7@57600:rsa")
    rate, colon, product = rest.partition(":")
    i = _int(ident, "--motor ID")
    if not 0 <= i <= 254:
        raise OptionError(f"--motor {text!r}: ID {i} is out of range; use 0..254")
    if colon and product not in PRODUCTS:
        raise OptionError(f"--motor {text!r}: unknown product {product!r}; use one of {', '.join(PRODUCTS)}")
    return i, check_baud(_int(rate, "--motor RATE")), (product if colon else None)


def parse_bool(text: str, what: str) -> bool:
    value = text.strip().lower()
    if value in ("1", "true", "yes", "on", ""):
        return True
    if value in ("0", "false", "no", "off"):
        return False
    raise OptionError(f"{what}={text!r}: use 0 or 1")
