"""Physical units <-> wire integers.

Rounding rule (every language follows it): a physical value becomes the nearest wire
step, halves rounded away from zero, computed in decimal so that binary floating
noise (180.005 stored as 180.00499999...) never shifts the result. Wire -> physical
is exact to the step's decimals (0.1 * 3 gives 0.3, not 0.30000000000000004).

Units: position in degrees (0.01 deg; 0.1 deg in speed feedback, erratum 6), speed
in RPM (0.1 RPM), current in amperes (0.1 A), arrival time in seconds (0.1 s),
response time in microseconds (100 us), reduction ratio as n:1 (0.1).
"""

from __future__ import annotations

import functools
import math
from decimal import ROUND_HALF_UP, Decimal, localcontext


def to_wire(value: float, scale: float) -> int:
    """Physical value -> wire integer (nearest step, halves away from zero)."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{value} is not a finite number")
    with localcontext() as ctx:
        ctx.prec = 800  # exact for every double: 1e30 must not overflow the default 28 digits
        steps = Decimal(repr(value)) / Decimal(repr(scale))
        return int(steps.quantize(Decimal(1), rounding=ROUND_HALF_UP))


def from_wire(raw: int, scale: float) -> float:
    """Wire integer -> physical value, exact to the scale's decimals."""
    return round(raw * scale, _decimals(scale))


@functools.lru_cache(maxsize=64)
def _decimals(scale: float) -> int:
    """Decimals of a scale (0.01 -> 2, 100 -> 0): worked out once per scale (every reading uses it)."""
    exponent = Decimal(repr(scale)).normalize().as_tuple().exponent
    return -exponent if isinstance(exponent, int) and exponent < 0 else 0


def degrees_to_wire(degrees: float, scale: float = 0.01) -> int:
    return to_wire(degrees, scale)


def rpm_to_wire(rpm: float) -> int:
    return to_wire(rpm, 0.1)


def amperes_to_wire(amperes: float) -> int:
    return to_wire(amperes, 0.1)


def seconds_to_wire(seconds: float) -> int:
    return to_wire(seconds, 0.1)


def microseconds_to_wire(microseconds: float) -> int:
    return to_wire(microseconds, 100)


def ratio_to_wire(ratio: float) -> int:
    """12.5 (meaning 12.5:1) -> 125."""
    return to_wire(ratio, 0.1)


# Suffixes accepted by parse_quantity, per unit, with their factor to that unit.
_SUFFIXES: dict[str, dict[str, float]] = {
    "us": {"us": 1, "µs": 1, "ms": 1000, "s": 1_000_000},
    "s": {"s": 1, "ms": 0.001, "us": 1e-6, "µs": 1e-6},
    "A": {"a": 1, "ma": 0.001},
    "deg": {"deg": 1, "°": 1},
    "rpm": {"rpm": 1},
    "ratio": {":1": 1},
}


def parse_quantity(text: str, unit: str) -> float:
    """'300us', '1.5 s', '12.5' -> a number in `unit` (ValueError if it is not a number)."""
    stripped = text.strip()
    factors = _SUFFIXES.get(unit, {})
    for suffix in sorted(factors, key=len, reverse=True):
        if stripped.lower().endswith(suffix):
            return float(stripped[: -len(suffix)].strip()) * factors[suffix]
    return float(stripped)
