"""One validation path for every number a person (or a file, or the network) gives us.

The CLI, the web console, backup files, `sim://` options and the simulator's options all
check values here, so that every refusal reads the same: which input, what was given, the
allowed range with its unit. Values are finite, in range and of the right type; a value the
wire would round is either refused or reported as rounded, never silently changed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .errors import InputError
from .protocol import FieldSpec, units

#: How each unit of spec/protocol.json is written for people (one spelling everywhere).
UNIT_SHOWN: dict[str, str] = {"deg": "°", "rpm": "RPM", "A": "A", "s": "s", "us": "µs", "ratio": ":1", "count": ""}

#: The longest text of a given value repeated in a message (the rest is cut, so an error stays one line).
SHOW_LIMIT = 40


def show(value: object) -> str:
    """A given value as a message repeats it: quoted if text, cut if long, always on one line."""
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]  # as JSON writes them
    try:
        text = repr(value) if isinstance(value, str) else str(value)
    except (RecursionError, ValueError):  # deeply nested lists; ints past Python's digit limit
        return f"a {type(value).__name__} too large to show"
    text = text.replace("\n", "\\n").replace("\r", "\\r")
    return text if len(text) <= SHOW_LIMIT else text[: SHOW_LIMIT - 3] + "..."


def with_unit(value: float | str, unit: str) -> str:
    """`90°`, `12.5:1`, `300 µs`, `2.5 A`: a value with its unit, spelled one way everywhere."""
    text = _fmt(value) if isinstance(value, int | float) else value
    if not unit:
        return text
    return f"{text}{unit}" if unit == "°" or unit.startswith(":") else f"{text} {unit}"


def range_text(low: float | None, high: float | None, unit: str) -> str:
    if low is not None and high is not None:
        if unit.startswith(":"):
            return f"{with_unit(low, unit)}..{with_unit(high, unit)}"
        return with_unit(f"{_fmt(low)}..{_fmt(high)}", unit)
    if low is not None:
        return ">= " + with_unit(low, unit)
    if high is not None:
        return "<= " + with_unit(high, unit)
    return with_unit("a finite number", unit)


def _fmt(x: float) -> str:
    x = float(x)
    if x.is_integer() and abs(x) < 1e16:
        return str(int(x))
    return f"{x:.10g}"


def number(
    value: object,
    name: str,
    low: float | None = None,
    high: float | None = None,
    unit: str = "",
    *,
    integer: bool = False,
    suffixes: str = "",
) -> float:
    """A finite number within [low, high] from a number or its text; else InputError.

    Booleans are refused (JSON `true` is not 1). With integer=True, 2.0 is accepted and 1.5 refused.
    With suffixes (a unit of spec/protocol.json, e.g. "us"), text may carry a unit: '300us', '0.3ms'.
    """
    wanted = range_text(low, high, unit)
    if isinstance(value, bool) or value is None:
        raise InputError(f"{name}: {show(value)} is not a number; give {wanted}")
    if isinstance(value, str):
        text = value.strip()
        if not text:
            raise InputError(f"{name}: empty; give {wanted}")
        if not text.isascii():  # float() reads fullwidth and Arabic-Indic digits; people and other languages do not
            raise InputError(f"{name}: {show(value)} is not a number (ASCII digits only); give {wanted}")
        try:
            result = units.parse_quantity(text, suffixes) if suffixes else float(text)
        except (ValueError, OverflowError):
            raise InputError(f"{name}: {show(value)} is not a number; give {wanted}") from None
    elif isinstance(value, int | float):
        try:
            result = float(value)
        except OverflowError:
            raise InputError(f"{name}: {show(value)} is too large; give {wanted}") from None
    else:
        raise InputError(f"{name}: {show(value)} is not a number; give {wanted}")
    if not math.isfinite(result):
        raise InputError(f"{name}: {show(value)} is not a finite number; give {wanted}")
    if integer and not result.is_integer():
        raise InputError(f"{name}: {show(value)} is not a whole number; give {wanted}")
    if (low is not None and result < low) or (high is not None and result > high):
        raise InputError(f"{name}: {show(value)} is out of range; give {wanted}")
    return result


def integer(value: object, name: str, low: int | None = None, high: int | None = None, unit: str = "") -> int:
    """A whole number within [low, high]; 3.0 is accepted, 3.5 refused."""
    return int(number(value, name, low, high, unit, integer=True))


def id_list(text: str, name: str = "--id") -> list[int]:
    """The one reading of a list of controller IDs (CLI options and the simulator alike):
    `1`, `1,2,5`, `0-3`, mixed `1,5-7`; each ID a whole number 0..254 in ASCII digits; a range
    goes up; space and empty items (`1,`) are ignored. In order, repeats kept: what a repeat
    means is the caller's (the CLI refuses or merges them; the simulator makes two controllers
    with one ID, a collision on purpose). InputError names the item otherwise."""
    ids: list[int] = []
    for part in text.split(","):
        item = part.strip()
        if not item:
            continue
        low_text, dash, high_text = item.partition("-")
        if dash and low_text:
            low, high = integer(low_text, name, 0, 254), integer(high_text, name, 0, 254)
            if high < low:
                raise InputError(f"{name}: {show(item)} is an empty range; write the low ID first, e.g. {high}-{low}")
            ids += range(low, high + 1)
        else:
            ids.append(integer(item, name, 0, 254))
    return ids


@dataclass(frozen=True, slots=True)
class Rounded:
    """A value as the wire will carry it, with what the person asked for (for 'kp 1.5 -> 2')."""

    asked: float
    wire: int
    physical: float

    @property
    def changed(self) -> bool:
        return not math.isclose(self.asked, self.physical, rel_tol=0, abs_tol=1e-9)

    def note(self, name: str, unit: str = "") -> str:
        return f"{name} {with_unit(self.asked, unit)} -> {with_unit(self.physical, unit)} (the wire's resolution)"


def quantize(value: float, scale: float) -> Rounded:
    """Round a physical value to the wire's steps (e.g. 0.01 deg), halves away from zero as the
    wire rounds (nurimc.protocol.units); the caller decides to warn or refuse."""
    wire = units.to_wire(value, scale)
    return Rounded(value, wire, units.from_wire(wire, scale))


def on_grid(
    value: object,
    name: str,
    step: float,
    low: float,
    high: float,
    unit: str = "",
    *,
    suffixes: str = "",
) -> Rounded:
    """number() within [low, high], then rounded to the wire's `step`. low and high lie on the grid,
    so the rounded value stays in range."""
    return quantize(number(value, name, low, high, unit, suffixes=suffixes), step)


def field_value(value: object, name: str, spec: FieldSpec, *, whole: bool = False) -> str | Rounded:
    """A value for one wire field, in physical units: the canonical name of a named value
    ('cw', 'relative') or the number rounded to the field's steps. Named fields take only their
    names (`control 1` would mean off: a surprise); counts (whole=True) refuse fractions."""
    if spec.values:
        names = {n: raw for raw, n in spec.values}
        if isinstance(value, str) and value.strip().lower() in names:
            return value.strip().lower()
        raise InputError(f"{name}: {show(value)} is not one of {', '.join(names)}")
    unit = UNIT_SHOWN.get(spec.unit, spec.unit)
    scale = spec.scale if spec.unit else 1
    low, high = units.from_wire(spec.min, scale), units.from_wire(spec.max, scale)
    if whole:
        exact = number(value, name, low, high, unit, integer=True, suffixes=spec.unit)
        return quantize(exact, scale)
    return on_grid(value, name, scale, low, high, unit, suffixes=spec.unit)


def json_document(
    data: bytes,
    where: str,
    what: str,
    error: type[InputError] = InputError,
    object_pairs_hook: Callable[[list[tuple[str, Any]]], Any] | None = None,
) -> Any:
    """Bytes from a file -> JSON, or one line naming `where` and saying it is not `what`
    (not UTF-8, nested too deeply, not JSON): files are read the same way everywhere."""
    try:
        return json.loads(data.decode("utf-8"), object_pairs_hook=object_pairs_hook)
    except UnicodeDecodeError:
        raise error(f"{where}: not UTF-8 text; not {what}") from None
    except RecursionError:
        raise error(f"{where}: nested too deeply; not {what}") from None
    except ValueError as problem:
        raise error(f"{where}: not JSON ({problem}); not {what}") from None
