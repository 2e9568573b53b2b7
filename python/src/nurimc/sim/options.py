"""Parsing what the CLI and the sim:// URL accept: controller lists and motors."""

from __future__ import annotations

from ..protocol import BAUD_RATES, PRODUCTS


class OptionError(ValueError):
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
    """Controller IDs: `1` -> ID 1, `0,1,2` -> those IDs, `0-31` -> IDs 0..31 (mixable: `1,5-7`).

    A single number is one ID, never a count: `sim://?ids=1` is the controller at ID 1."""
    ids: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        first, dash, last = part.partition("-")
        low = _int(first, "--ids") if first.strip() else -1
        high = _int(last, "--ids") if dash else low
        for i in (low, high):
            if not 0 <= i <= 254:
                raise OptionError(f"--ids {part!r}: ID {i} is out of range; use 0..254 (e.g. 1, 0,1,2 or 0-31)")
        if high < low:
            raise OptionError(f"--ids {part!r}: a range goes up, e.g. {high}-{low}")
        ids.extend(range(low, high + 1))
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
