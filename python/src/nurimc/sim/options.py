"""Parsing what the CLI and the sim:// URL accept: controller lists and motors."""

from __future__ import annotations

from ..protocol import BAUD_RATES


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
        return int(text.strip(), 0)
    except ValueError:
        raise OptionError(f"{what}: {text!r} is not a number") from None


def parse_ids(text: str) -> list[int]:
    """`0,1,2` -> those IDs; a single number N -> N controllers at IDs 0..N-1; `5,` -> just ID 5."""
    text = text.strip()
    if not text:
        return []
    if "," not in text:
        count = _int(text, "--ids")
        if not 1 <= count <= 254:
            raise OptionError(f"--ids {count}: a count must be 1..254 (for the single ID {count}, write '{count},')")
        return list(range(count))
    ids = [_int(part, "--ids") for part in text.split(",") if part.strip()]
    for i in ids:
        if not 0 <= i <= 254:
            raise OptionError(f"--ids: ID {i} is out of range; use 0..254")
    return ids


def parse_motor(text: str) -> tuple[int, int]:
    """`ID@RATE` (e.g. 3@57600) -> (3, 57600)."""
    ident, sep, rate = text.partition("@")
    if not sep:
        raise OptionError(f"--motor {text!r}: write ID@RATE, e.g. 3@57600")
    i = _int(ident, "--motor ID")
    if not 0 <= i <= 254:
        raise OptionError(f"--motor {text!r}: ID {i} is out of range; use 0..254")
    return i, check_baud(_int(rate, "--motor RATE"))


def parse_bool(text: str, what: str) -> bool:
    value = text.strip().lower()
    if value in ("1", "true", "yes", "on", ""):
        return True
    if value in ("0", "false", "no", "off"):
        return False
    raise OptionError(f"{what}={text!r}: use 0 or 1")
