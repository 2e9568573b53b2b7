"""The JSON-lines conformance program (conformance/README.md): one answer line per input line.

The line contract (what a line is, strict JSON, integers written as integers, the nesting
and size limits) is checked here, before a request reaches the protocol code.
"""

from __future__ import annotations

import json
import re
import sys
from collections.abc import Iterator
from typing import Any, BinaryIO

from .core.buscore import BusCore
from .errors import ValueOutOfRange
from .procedures.motor import MotorProcedures
from .procedures.multiturn import signed_degrees
from .procedures.settings import SETTINGS
from .protocol import DecodeError, EncodeError, Line, StreamParser, UnknownLineError, line, units

MAX_LINE_BYTES = 4 * 1024 * 1024
MAX_DEPTH = 64
# An integer literal longer than this is beyond every wire range; keep it cheap to convert.
_LONGEST_INTEGER = 40
_HUGE: int = 10**_LONGEST_INTEGER

_HEX = re.compile(r"(?:[0-9a-fA-F]{2})*")
_SURROGATE = re.compile("[\ud800-\udfff]")
_JSON_SPACE = frozenset(b" \t\r")


class BadRequest(Exception):
    """A line that is not one request object under the line contract."""


class _Float:
    """A number written with a fraction or an exponent: never an integer, whatever its value."""

    def __init__(self, text: str) -> None:
        self.text = text

    def __repr__(self) -> str:
        return self.text


def _integer(text: str) -> int:
    digits = text.lstrip("-")
    if len(digits) > _LONGEST_INTEGER:
        return -_HUGE if text.startswith("-") else _HUGE
    return int(text)


def _no_constant(name: str) -> Any:
    raise BadRequest(f"not JSON: {name}")


class _Object(dict[str, Any]):
    """A JSON object that keeps the values its duplicate keys overrode: the line contract holds
    for every value on the line, also one a later key replaces (conformance/README.md)."""

    overridden: list[Any]


def _object(pairs: list[tuple[str, Any]]) -> _Object:
    obj = _Object()
    obj.overridden = []
    for key, value in pairs:
        if key in obj:
            obj.overridden.append(obj[key])
        obj[key] = value
    return obj


_DECODER = json.JSONDecoder(
    parse_float=_Float, parse_int=_integer, parse_constant=_no_constant, object_pairs_hook=_object
)


def _check_tree(value: Any, depth: int = 1) -> None:
    """Nesting limit and well-formed strings (no lone surrogates), keys included."""
    if isinstance(value, (dict, list)):
        if depth > MAX_DEPTH:
            raise BadRequest(f"nested deeper than {MAX_DEPTH} levels")
        items = value.items() if isinstance(value, dict) else enumerate(value)
        for key, item in items:
            if isinstance(key, str) and _SURROGATE.search(key):
                raise BadRequest("a string holds a lone surrogate")
            _check_tree(item, depth + 1)
        for item in getattr(value, "overridden", ()):
            _check_tree(item, depth + 1)
    elif isinstance(value, str) and _SURROGATE.search(value):
        raise BadRequest("a string holds a lone surrogate")


def read_request(raw: bytes) -> Any:
    """The JSON value of one line (without its newline), or BadRequest."""
    if all(b in _JSON_SPACE for b in raw):
        raise BadRequest("empty line")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise BadRequest(f"not UTF-8: {err.reason} at byte {err.start}") from None
    try:
        value = _DECODER.decode(text)
    except RecursionError:
        raise BadRequest(f"nested deeper than {MAX_DEPTH} levels") from None
    except ValueError as err:  # JSONDecodeError is a ValueError
        raise BadRequest(f"not JSON: {err}") from None
    _check_tree(value)
    return value


def _bytes(text: object) -> bytes:
    """Contiguous hex digit pairs, either case; anything else is `bad_hex` (a ValueError)."""
    if not isinstance(text, str) or not _HEX.fullmatch(text):
        raise ValueError(f"not hex: {text!r}")
    return bytes.fromhex(text)


def _line(request: dict[str, Any]) -> Line:
    """The request's product line: "line" (spec/lines.json), MC when absent."""
    return line(request["line"]) if "line" in request else line("mc")


def _parse(request: dict[str, Any]) -> dict[str, Any]:
    chunks = request.get("chunks")
    if chunks is None:
        pieces = [_bytes(request.get("hex"))]
    elif isinstance(chunks, list):
        pieces = [_bytes(chunk) for chunk in chunks]
    else:
        raise ValueError("chunks is not a list")
    parser = StreamParser(line=_line(request).key)
    frames = []
    for piece in pieces:
        frames += parser.feed(piece)
    frames += parser.finish()
    return {"frames": [m.to_dict() for m in frames], "dropped_bytes": parser.stats.dropped_bytes}


# The units ops (conformance/README.md, "units"): the library's own conversions. The motion
# builders only check and convert; this handle never touches a bus.
_MOTION = MotorProcedures(BusCore(), 1)
_QUANTITIES = frozenset(["degrees", "rpm", "seconds", *SETTINGS])


class _UnitError(Exception):
    def __init__(self, kind: str) -> None:
        super().__init__(kind)
        self.kind = kind


def _number(value: object) -> float | None:
    """A JSON number as the double every JSON reader makes of it (None: not a number)."""
    if isinstance(value, _Float):
        return float(value.text)
    if isinstance(value, float):  # a request built in Python (answer() called directly)
        return value
    if isinstance(value, int) and not isinstance(value, bool):
        return float(value) if abs(value) < _HUGE else float("inf") if value > 0 else float("-inf")
    return None


def _integer_in(value: object, top: int) -> int:
    if not isinstance(value, int) or isinstance(value, bool):
        raise _UnitError("type")
    if not 0 <= value <= top:
        raise _UnitError("range")
    return value


def _quantity(request: dict[str, Any]) -> str:
    quantity = request.get("quantity")
    if not isinstance(quantity, str) or quantity not in _QUANTITIES:
        raise _UnitError("unknown_quantity")
    return quantity


def _to_wire(request: dict[str, Any]) -> dict[str, Any]:
    quantity = _quantity(request)
    value = request.get("value")
    number = _number(value)
    choice = quantity in SETTINGS and bool(SETTINGS[quantity].spec.values)
    if number is None and not (isinstance(value, str) and choice):
        raise _UnitError("type")
    try:
        if number is None:  # a value name of a choice setting
            return {"wire": SETTINGS[quantity].to_wire(value)}
        if quantity == "degrees":
            move = _MOTION.make_move_to(number, rpm=1).fields()
            return {"direction": move["direction"], "wire": move["position"]}
        if quantity == "rpm":
            run = _MOTION.make_run(number).fields()
            return {"direction": run["direction"], "wire": run["speed"]}
        if quantity == "seconds":
            return {"wire": _MOTION.make_run(1, ramp_seconds=number).fields()["arrival_time"]}
        return {"wire": SETTINGS[quantity].to_wire(number)}
    except ValueOutOfRange:
        raise _UnitError("range") from None


def _from_wire(request: dict[str, Any]) -> dict[str, Any]:
    quantity = _quantity(request)
    wire = _integer_in(request.get("wire"), 65535)
    if quantity in ("degrees", "rpm"):
        direction = _integer_in(request.get("direction"), 1)
        value = signed_degrees(direction, units.from_wire(wire, 0.01 if quantity == "degrees" else 0.1))
        return {"value": value or 0.0}  # zero has no sign: never -0.0 (conformance/README.md)
    if quantity == "seconds":
        return {"value": units.from_wire(wire, 0.1)}
    return {"value": SETTINGS[quantity].to_physical(wire)}


def answer(request: Any) -> dict[str, Any]:
    if not isinstance(request, dict):
        return {"error": "bad_request", "detail": "each line must be a JSON object"}
    op = request.get("op")
    try:
        if op == "decode":
            return _line(request).decode(_bytes(request.get("hex"))).to_dict()
        if op == "encode":
            product_line = _line(request)
            fields = {k: v for k, v in request.items() if k not in ("op", "id", "message", "line")}
            for key in ("message", "id"):
                if key not in request:
                    return {"error": "missing_field", "field": key}
            if not isinstance(request["message"], str):
                return {"error": "unknown_message"}
            return {"hex": product_line.make(request["message"], request["id"], **fields).encode().hex()}
        if op == "parse":
            return _parse(request)
        if op == "to_wire":
            return _to_wire(request)
        if op == "from_wire":
            return _from_wire(request)
    except _UnitError as err:
        return {"error": err.kind}
    except UnknownLineError:
        return {"error": "unknown_line"}
    except DecodeError as err:
        return {"error": err.kind}
    except EncodeError as err:
        out: dict[str, Any] = {"error": err.kind}
        if err.field is not None:
            out["field"] = err.field
        return out
    except ValueError:
        return {"error": "bad_hex"}
    return {"error": "unknown_op"}


def answer_line(raw: bytes) -> dict[str, Any]:
    """The answer to one input line (bytes without the newline)."""
    try:
        request = read_request(raw)
    except BadRequest as err:
        return {"error": "bad_request", "detail": str(err)}
    return answer(request)


def lines(stream: BinaryIO) -> Iterator[bytes | None]:
    """Each line's bytes (LF ends a line; a last unterminated line counts); an overlong
    line is read past without being kept and comes out as None."""
    while True:
        raw = stream.readline(MAX_LINE_BYTES + 1)
        if not raw:
            return
        if raw.endswith(b"\n"):
            yield raw[:-1]
        elif len(raw) <= MAX_LINE_BYTES:
            yield raw  # the last line, without a newline
        else:
            while raw and not raw.endswith(b"\n"):
                raw = stream.readline(MAX_LINE_BYTES)
            yield None


def serve(stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
    source = stdin if stdin is not None else sys.stdin.buffer
    sink = stdout if stdout is not None else sys.stdout.buffer
    for raw in lines(source):
        if raw is None:
            reply: dict[str, Any] = {"error": "bad_request", "detail": f"line longer than {MAX_LINE_BYTES} bytes"}
        else:
            reply = answer_line(raw)
        sink.write(json.dumps(reply).encode("ascii") + b"\n")
        sink.flush()


if __name__ == "__main__":
    serve()
