#!/usr/bin/env python3
"""Write the conformance vectors in spec/vectors/ from spec/protocol.json.

The expected answers come from the small reference model in this file (frame
building, the whole-frame checks, and the stream rule stated in
conformance/README.md), written from the document and independent of every
language implementation. `--check` fails when the committed vectors are stale.

Usage: python3 tools/make_vectors.py [--check]
"""

from __future__ import annotations

import itertools
import json
import math
import random
import sys
from decimal import ROUND_HALF_UP, Decimal, localcontext
from typing import Any

import speclib

SPEC = speclib.load()
MESSAGES = {m["name"]: m for m in SPEC["messages"]}
BY_MODE = {m["mode"]: m for m in SPEC["messages"]}
HEADER = bytes(SPEC["frame"]["header"])
OUT = speclib.ROOT / "spec" / "vectors"


# ---- reference model -------------------------------------------------------


def frame(msg_id: int, mode: int, data: bytes) -> bytes:
    size = len(data) + 2
    checksum = ~(msg_id + size + mode + sum(data)) & 0xFF
    return HEADER + bytes([msg_id, size, checksum, mode]) + data


def encode(name: str, msg_id: int, fields: dict[str, int]) -> bytes:
    msg = MESSAGES[name]
    data = b"".join(fields[f["name"]].to_bytes(f["width"], "big") for f in msg["fields"])
    return frame(msg_id, msg["mode"], data)


def decode(raw: bytes) -> dict[str, Any]:
    """The conformance decode answer for one whole frame (checks in the documented order)."""
    if raw[:2] != HEADER[: len(raw[:2])]:  # judged on the header bytes present
        return {"error": "header"}
    if len(raw) < 6 or len(raw) < raw[3] + 4:
        return {"error": "truncated"}
    if len(raw) > raw[3] + 4:
        return {"error": "trailing"}
    if ~sum(raw[2:4] + raw[5:]) & 0xFF != raw[4]:
        return {"error": "checksum"}
    msg = BY_MODE.get(raw[5])
    if msg is None:
        return {"error": "unknown_mode"}
    if raw[3] != msg["size"]:
        return {"error": "size"}
    out: dict[str, Any] = {"id": raw[2], "message": msg["name"]}
    offset = 6
    for f in msg["fields"]:
        out[f["name"]] = int.from_bytes(raw[offset : offset + f["width"]], "big")
        offset += f["width"]
    return out


def scan(stream: bytes) -> dict[str, Any]:
    """The stream rule: from each position take a whole valid frame, else drop one byte."""
    frames, dropped, pos = [], 0, 0
    while pos < len(stream):
        size = stream[pos + 3] if pos + 3 < len(stream) else 0
        candidate = stream[pos : pos + size + 4]
        result = decode(candidate) if len(candidate) >= 6 else {"error": "truncated"}
        if "error" in result:
            dropped += 1
            pos += 1
        else:
            frames.append(result)
            pos += len(candidate)
    return {"frames": frames, "dropped_bytes": dropped}


# ---- vector sets -----------------------------------------------------------


def hexs(raw: bytes) -> str:
    return raw.hex()


def unspaced(printed: str) -> bytes:
    return bytes.fromhex(printed.replace(" ", ""))


def vec(name: str, request: dict[str, Any], expect: dict[str, Any]) -> dict[str, Any]:
    return {"name": name, "input": request, "expect": expect}


def encode_request(name: str, msg_id: int, fields: dict[str, Any]) -> dict[str, Any]:
    return {"op": "encode", "id": msg_id, "message": name, **fields}


def example_vectors() -> list[dict[str, Any]]:
    out = []
    for ex in SPEC["examples"]:
        raw = unspaced(ex["hex"])
        tag = f"example §{ex['section']} {ex['meaning']}" + (" (corrected)" if "erratum" in ex else "")
        expected = {"id": ex["id"], "message": ex["message"], **ex["fields"]}
        assert encode(ex["message"], ex["id"], ex["fields"]) == raw, tag
        assert decode(raw) == expected, tag
        out.append(vec(tag + ": decode", {"op": "decode", "hex": hexs(raw)}, expected))
        out.append(vec(tag + ": encode", encode_request(ex["message"], ex["id"], ex["fields"]), {"hex": hexs(raw)}))
    return out


def errata_vectors() -> list[dict[str, Any]]:
    """The printed (wrong) frames decode to what they really are."""
    out = []
    for ex in SPEC["examples"]:
        if "printed" not in ex:
            continue
        raw = unspaced(ex["printed"])
        tag = f"erratum {ex['erratum']} §{ex['section']} as printed"
        out.append(vec(tag + ": decode", {"op": "decode", "hex": hexs(raw)}, decode(raw)))
        out.append(vec(tag + ": in a stream", {"op": "parse", "hex": hexs(raw)}, scan(raw)))
    return out


def typical(field: dict[str, Any]) -> int:
    return (field["min"] + field["max"]) // 2 + (7 if field["max"] - field["min"] > 20 else 0)


def message_vectors() -> list[dict[str, Any]]:
    out = []
    for msg in SPEC["messages"]:
        name, fields = msg["name"], msg["fields"]
        ids = {"min": 0, "max": msg["max_id"], "typical": 17}
        cases = {
            "min": {f["name"]: f["min"] for f in fields},
            "max": {f["name"]: f["max"] for f in fields},
            "typical": {f["name"]: typical(f) for f in fields},
        }
        for case, values in cases.items():
            raw = encode(name, ids[case], values)
            tag = f"{name} {case}"
            out.append(vec(tag + ": encode", encode_request(name, ids[case], values), {"hex": hexs(raw)}))
            out.append(vec(tag + ": decode", {"op": "decode", "hex": hexs(raw)}, decode(raw)))
        if msg["kind"] == "command":
            raw = encode(name, 0xFF, cases["typical"])
            out.append(
                vec(f"{name} broadcast: encode", encode_request(name, 0xFF, cases["typical"]), {"hex": hexs(raw)})
            )
            out.append(vec(f"{name} broadcast: decode", {"op": "decode", "hex": hexs(raw)}, decode(raw)))
        else:
            out.append(
                vec(
                    f"{name} id 255 is broadcast, not allowed",
                    encode_request(name, 0xFF, cases["typical"]),
                    {"error": "range", "field": "id"},
                )
            )
        out.append(
            vec(f"{name} id 256", encode_request(name, 256, cases["typical"]), {"error": "range", "field": "id"})
        )
        out.append(vec(f"{name} id -1", encode_request(name, -1, cases["typical"]), {"error": "range", "field": "id"}))
        for f in fields:
            for bad in (f["min"] - 1, f["max"] + 1, 1 << (8 * f["width"])):
                if 0 <= bad < (1 << 8 * f["width"]) and f["min"] <= bad <= f["max"]:
                    continue
                values = dict(cases["typical"], **{f["name"]: bad})
                out.append(
                    vec(
                        f"{name}.{f['name']} = {bad} out of range",
                        encode_request(name, 1, values),
                        {"error": "range", "field": f["name"]},
                    )
                )
            values = dict(cases["typical"])
            del values[f["name"]]
            out.append(
                vec(
                    f"{name} without {f['name']}",
                    encode_request(name, 1, values),
                    {"error": "missing_field", "field": f["name"]},
                )
            )
            for wrong in ("12", 1.5, True, None):
                values = dict(cases["typical"], **{f["name"]: wrong})
                out.append(
                    vec(
                        f"{name}.{f['name']} = {wrong!r} is not an integer",
                        encode_request(name, 1, values),
                        {"error": "type", "field": f["name"]},
                    )
                )
        if fields:
            # Out-of-range values in an otherwise valid frame decode as they are.
            values = {f["name"]: (1 << 8 * f["width"]) - 1 for f in fields}
            raw = encode(name, 3, values)
            out.append(
                vec(f"{name} with every field 0xFF..: decode as is", {"op": "decode", "hex": hexs(raw)}, decode(raw))
            )
        values = dict(cases["typical"], bogus=1)
        out.append(
            vec(
                f"{name} with an unknown field",
                encode_request(name, 1, values),
                {"error": "unknown_field", "field": "bogus"},
            )
        )
    out.append(vec("unknown message", {"op": "encode", "id": 0, "message": "warp_drive"}, {"error": "unknown_message"}))
    out.append(vec("message missing", {"op": "encode", "id": 0}, {"error": "missing_field", "field": "message"}))
    out.append(
        vec("id missing", {"op": "encode", "message": "request_ping"}, {"error": "missing_field", "field": "id"})
    )
    out.append(
        vec(
            "id not an integer",
            {"op": "encode", "id": "0", "message": "request_ping"},
            {"error": "type", "field": "id"},
        )
    )
    return out


def broken_vectors() -> list[dict[str, Any]]:
    ping = encode("request_ping", 0, {})
    feedback = encode("position_feedback", 5, {"direction": 1, "position": 12345, "speed": 300, "current": 12})
    cases: list[tuple[str, bytes]] = [
        ("empty", b""),
        ("one byte FF", b"\xff"),
        ("one byte 00", b"\x00"),
        ("header FF FF", b"\xff\xff" + feedback[2:]),
        ("header FE FF", b"\xfe\xff" + feedback[2:]),
        ("header only", HEADER),
        ("five bytes", ping[:5]),
        ("size 0", HEADER + b"\x00\x00\xff\xa0"),
        ("size 1", HEADER + b"\x00\x01\xfe\xa0"),
        ("one byte short", feedback[:-1]),
        ("header, id and size only", feedback[:4]),
        ("one byte too many", feedback + b"\x00"),
        ("two frames", ping + ping),
        ("checksum off by one", feedback[:4] + bytes([(feedback[4] + 1) & 0xFF]) + feedback[5:]),
        ("data bit flipped", feedback[:-1] + bytes([feedback[-1] ^ 0x04])),
        ("id changed", feedback[:2] + b"\x06" + feedback[3:]),
        ("unknown mode 0x00", frame(0, 0x00, b"")),
        ("unknown mode 0x11", frame(0, 0x11, b"")),
        ("unknown mode 0xAC", frame(0, 0xAC, b"")),
        ("unknown mode 0xFF", frame(0, 0xFF, b"\x01")),
        ("unknown mode 0x30 (other product line)", frame(1, 0x30, b"\x01\x02")),
        ("size too small for position_speed", frame(0, 0x01, b"\x00\x46\x50\x03")),
        ("size too large for request_ping", frame(0, 0xA0, b"\x00")),
        ("size too large for position_feedback", frame(0, 0xD1, b"\x00" * 7)),
        ("command with no data", frame(0, 0x06, b"")),
    ]
    out = []
    for tag, raw in cases:
        expect = decode(raw)
        assert "error" in expect, tag
        out.append(vec(f"broken: {tag}", {"op": "decode", "hex": hexs(raw)}, expect))
    for bad in ("zz", "fff", "ff fe"):
        out.append(vec(f"not hex: {bad!r}", {"op": "decode", "hex": bad}, {"error": "bad_hex"}))
    out.append(vec("unknown op", {"op": "teleport"}, {"error": "unknown_op"}))
    return out


def stream_vectors() -> list[dict[str, Any]]:
    rng = random.Random(485)
    ping_req = encode("request_ping", 0, {})
    pos_req = encode("request_position", 7, {})
    pos_ans = encode("position_feedback", 7, {"direction": 0, "position": 18000, "speed": 0, "current": 0})
    ffe_inside = encode("position_speed", 2, {"direction": 1, "position": 0x12FF, "speed": 0xFE01})
    gains = encode("position_gains", 1, {"kp": 254, "ki": 255, "kd": 254, "rated_current": 80})
    reset = encode("factory_reset", 0xFF, {})
    frames = [ping_req, pos_req, pos_ans, ffe_inside, gains, reset, encode("firmware", 9, {"version": 255})]
    out: list[dict[str, Any]] = []

    def add(tag: str, stream: bytes, chunks: list[bytes] | None = None) -> None:
        request: dict[str, Any] = {"op": "parse"}
        if chunks is None:
            request["hex"] = hexs(stream)
        else:
            assert b"".join(chunks) == stream
            request["chunks"] = [hexs(c) for c in chunks]
        out.append(vec(f"stream: {tag}", request, scan(stream)))

    add("empty", b"")
    add("one frame", pos_ans)
    add("all sample frames back to back", b"".join(frames))
    joined = pos_req + pos_ans + ffe_inside
    for cut in range(1, len(joined)):
        add(f"three frames split at byte {cut}", joined, [joined[:cut], joined[cut:]])
    add("three frames fed one byte at a time", joined, [bytes([b]) for b in joined])
    add("noise before", b"\x00\x13\xfe\xff\x55" + pos_ans)
    add("noise between", pos_req + b"\xaa\xff\x00" + pos_ans)
    add("noise after", pos_ans + b"\x01\xff")
    add("trailing FF", pos_ans + b"\xff")
    add("trailing header", pos_ans + HEADER)
    add("FF FE inside data", ffe_inside + pos_ans)
    add("false header claiming 8 bytes, then a real frame", HEADER + b"\x00\x08" + ping_req)
    add("false header claiming 255 bytes, then a real frame", HEADER + b"\x00\xff" + pos_ans)
    add("false header with a known mode, then a real frame", HEADER + b"\x07\x08\x00\xd1\x00" + pos_ans)
    add("truncated frame, then a real frame", pos_ans[:9] + pos_ans)
    add("frame with a bad checksum, then a real frame", pos_ans[:4] + b"\x00" + pos_ans[5:] + ping_req)
    add("host's request echoed before the answer", pos_req + pos_ans)
    add("header bytes doubled", b"\xff" + pos_ans)
    add("FF FE FE", HEADER + pos_ans[1:])
    for printed in ("FF FF 00 04 8C 0B 00 64", "FF FE 00 03 EC 0F 01"):
        add(f"printed erratum frame {printed} between frames", ping_req + unspaced(printed) + pos_ans)
    for i in range(12):
        parts = []
        for _ in range(rng.randint(1, 6)):
            if rng.random() < 0.6:
                parts.append(rng.choice(frames))
            else:
                parts.append(
                    bytes(rng.choice([0xFF, 0xFE, 0x00, rng.randrange(256)]) for _ in range(rng.randint(1, 9)))
                )
        stream = b"".join(parts)
        cuts = sorted(rng.sample(range(1, len(stream)), min(3, len(stream) - 1))) if len(stream) > 1 else []
        bounds = [0, *cuts, len(stream)]
        add(f"random mix {i}", stream, [stream[a:b] for a, b in itertools.pairwise(bounds)])
    for i in range(4):
        noise = bytes(rng.randrange(256) for _ in range(64))
        add(f"random noise {i}", noise)
    return out


# ---- the line contract (conformance/README.md) -----------------------------

MAX_LINE_BYTES = 4 * 1024 * 1024
MAX_DEPTH = 64
BAD_REQUEST = {"error": "bad_request"}


def line_vec(name: str, pieces: list[tuple[str, int]], expect: dict[str, Any]) -> dict[str, Any]:
    """A vector whose line is raw text: each piece repeated, joined (no newline inside)."""
    assert all("\n" not in text for text, _ in pieces), name
    return {"name": name, "line": [[text, times] for text, times in pieces], "expect": expect}


def bytes_vec(name: str, raw: bytes, expect: dict[str, Any]) -> dict[str, Any]:
    assert b"\n" not in raw, name
    return {"name": name, "line_bytes": raw.hex(), "expect": expect}


def edge_vectors() -> list[dict[str, Any]]:
    ping = encode("request_ping", 0, {})
    pos_ans = encode("position_feedback", 7, {"direction": 0, "position": 18000, "speed": 0, "current": 0})
    decoded_ping = decode(ping)
    decoded_ans = decode(pos_ans)
    decode_line = json.dumps({"op": "decode", "hex": hexs(pos_ans)}, separators=(",", ":"))
    gains = {"kp": 1, "ki": 2, "kd": 3, "rated_current": 4}
    out: list[dict[str, Any]] = []

    # lines: what one is, and that each gets exactly one answer
    out.append(line_vec("empty line", [], BAD_REQUEST))
    out.append(line_vec("blank line (spaces and a tab)", [("  \t ", 1)], BAD_REQUEST))
    out.append(line_vec("line of a lone \\r", [("\r", 1)], BAD_REQUEST))
    out.append(line_vec("\\r\\n line ending", [(decode_line + "\r", 1)], decoded_ans))
    out.append(line_vec("\\r between tokens is whitespace", [(decode_line.replace(",", "\r,"), 1)], decoded_ans))
    out.append(
        line_vec(
            "\\r alone in the middle of a line is no line end",
            [('{"op":"decode",\r"hex":"' + hexs(ping) + '"}', 1)],
            decoded_ping,
        )
    )
    out.append(line_vec("raw \\r inside a string", [('{"op":"decode","hex":"ff\rfe"}', 1)], BAD_REQUEST))
    out.append(line_vec("raw tab inside a string", [('{"op":"decode\t"}', 1)], BAD_REQUEST))
    out.append(line_vec("leading and trailing whitespace", [(" \t" + decode_line + " \t ", 1)], decoded_ans))
    out.append(line_vec("not JSON", [("hello", 1)], BAD_REQUEST))
    out.append(line_vec("two objects on one line", [(decode_line + decode_line, 1)], BAD_REQUEST))
    for text in ("[]", "1", '"decode"', "null", "true"):
        out.append(line_vec(f"top-level {text} is no object", [(text, 1)], BAD_REQUEST))
    # a number with a fraction or an exponent is no object either, however large (conformance/README.md)
    for text in ("1e400", "-1e400", "1.5", "-0.0", "1E2"):
        out.append(line_vec(f"top-level float {text} is no object", [(text, 1)], BAD_REQUEST))

    # encodings
    out.append(bytes_vec("raw NUL byte after the object", decode_line.encode() + b"\x00", BAD_REQUEST))
    out.append(bytes_vec("raw NUL byte inside a string", b'{"op":"dec\x00ode"}', BAD_REQUEST))
    out.append(bytes_vec("invalid UTF-8 (lone continuation byte) in a string", b'{"op":"\x80"}', BAD_REQUEST))
    out.append(bytes_vec("invalid UTF-8 (0xFF) in a string", b'{"op":"decode","hex":"\xff"}', BAD_REQUEST))
    out.append(bytes_vec("overlong UTF-8 of '/'", b'{"op":"\xc0\xaf"}', BAD_REQUEST))
    out.append(bytes_vec("UTF-8-encoded surrogate", b'{"op":"\xed\xa0\x80"}', BAD_REQUEST))
    out.append(bytes_vec("truncated UTF-8 sequence", b'{"op":"\xe2\x82"}', BAD_REQUEST))
    out.append(bytes_vec("byte order mark", b"\xef\xbb\xbf" + decode_line.encode(), BAD_REQUEST))
    out.append(line_vec("escaped lone high surrogate", [('{"op":"\\ud800"}', 1)], BAD_REQUEST))
    out.append(line_vec("escaped lone low surrogate", [('{"op":"x\\udc00y"}', 1)], BAD_REQUEST))
    out.append(
        line_vec("escaped surrogate pair is one character", [('{"op":"\\ud83d\\ude00"}', 1)], {"error": "unknown_op"})
    )
    out.append(
        line_vec(
            "valid UTF-8 key is an unknown field, echoed",
            [('{"op":"encode","id":0,"message":"request_ping","\u00e9t\u00e9":1}', 1)],
            {"error": "unknown_field", "field": "\u00e9t\u00e9"},
        )
    )

    # strict JSON
    for text in ("NaN", "Infinity", "-Infinity", "01", "+1", ".5", "1.", "-", "1e", "0x10", "'x'"):
        out.append(
            line_vec(
                f"{text} is not a JSON value",
                [('{"op":"encode","id":0,"message":"request_ping","x":' + text + "}", 1)],
                BAD_REQUEST,
            )
        )
    out.append(
        line_vec(
            "NaN as a field value",
            [('{"op":"encode","id":1,"message":"position_gains","kp":NaN,"ki":2,"kd":3,"rated_current":4}', 1)],
            BAD_REQUEST,
        )
    )
    out.append(
        line_vec("Infinity as the id", [('{"op":"encode","id":Infinity,"message":"request_ping"}', 1)], BAD_REQUEST)
    )
    out.append(line_vec("trailing comma", [('{"op":"decode","hex":"",}', 1)], BAD_REQUEST))
    out.append(line_vec("comment", [('{"op":"decode"/* c */,"hex":""}', 1)], BAD_REQUEST))
    out.append(line_vec("single-quoted key", [("{'op':'decode'}", 1)], BAD_REQUEST))
    out.append(line_vec("unquoted key", [('{op:"decode"}', 1)], BAD_REQUEST))
    out.append(line_vec("bad escape", [('{"op":"\\x41"}', 1)], BAD_REQUEST))
    out.append(line_vec("unterminated string", [('{"op":"decode', 1)], BAD_REQUEST))
    out.append(line_vec("unclosed object", [('{"op":"decode","hex":""', 1)], BAD_REQUEST))
    out.append(
        line_vec(
            "duplicate keys: the last one counts",
            [('{"op":"encode","op":"decode","hex":"00","hex":"' + hexs(ping) + '"}', 1)],
            decoded_ping,
        )
    )
    # the line contract holds for the whole line: a value a later duplicate overrides is still read
    out.append(
        line_vec(
            "lone surrogate in a value a later duplicate key overrides",
            [('{"op":"decode","hex":"\\ud800","hex":"' + hexs(ping) + '"}', 1)],
            BAD_REQUEST,
        )
    )
    out.append(
        line_vec(
            "lone surrogate in a key no operation reads",
            [('{"op":"decode","x\\udc00":1,"hex":"' + hexs(ping) + '"}', 1)],
            BAD_REQUEST,
        )
    )
    out.append(
        line_vec(
            f"nesting {MAX_DEPTH + 1} levels in a value a later duplicate key overrides",
            [('{"op":"decode","hex":', 1), ("[", MAX_DEPTH), ("]", MAX_DEPTH), (',"hex":"' + hexs(ping) + '"}', 1)],
            BAD_REQUEST,
        )
    )
    out.append(
        line_vec(
            "escapes in names are names", [('{"\\u006fp":"\\u0064ecode","hex":"' + hexs(ping) + '"}', 1)], decoded_ping
        )
    )

    # numbers: integers are written as integers
    for text in ("0.0", "1.0", "-0.0", "1e2", "1E0", "2.5e1", "1e400", "-1e400", "1e-400"):
        out.append(
            line_vec(
                f"{text} is not an integer (field)",
                [
                    (
                        '{"op":"encode","id":1,"message":"position_gains","kp":'
                        + text
                        + ',"ki":2,"kd":3,"rated_current":4}',
                        1,
                    )
                ],
                {"error": "type", "field": "kp"},
            )
        )
        out.append(
            line_vec(
                f"{text} is not an integer (id)",
                [('{"op":"encode","id":' + text + ',"message":"request_ping"}', 1)],
                {"error": "type", "field": "id"},
            )
        )
    out.append(
        line_vec(
            "-0 is the integer 0",
            [('{"op":"encode","id":-0,"message":"position_gains","kp":1,"ki":-0,"kd":3,"rated_current":4}', 1)],
            {"hex": hexs(encode("position_gains", 0, dict(gains, ki=0)))},
        )
    )
    for text in ("9007199254740993", "123456789012345678901234567890", "1" + "0" * 5000, "-" + "9" * 5000):
        label = (
            text
            if len(text) < 40
            else f"an integer of {len(text.lstrip('-'))} digits{' (negative)' if text[0] == '-' else ''}"
        )
        out.append(
            line_vec(
                f"{label} is out of range (field)",
                [
                    (
                        '{"op":"encode","id":1,"message":"position_gains","kp":'
                        + text
                        + ',"ki":2,"kd":3,"rated_current":4}',
                        1,
                    )
                ],
                {"error": "range", "field": "kp"},
            )
        )
        out.append(
            line_vec(
                f"{label} is out of range (id)",
                [('{"op":"encode","id":' + text + ',"message":"request_ping"}', 1)],
                {"error": "range", "field": "id"},
            )
        )

    # NUL and other characters inside strings: strings compare whole
    out.append(
        vec(
            "NUL after a message name",
            {"op": "encode", "id": 0, "message": "request_ping\u0000"},
            {"error": "unknown_message"},
        )
    )
    out.append(
        vec(
            "NUL before a message name",
            {"op": "encode", "id": 0, "message": "\u0000request_ping"},
            {"error": "unknown_message"},
        )
    )
    out.append(vec("NUL inside hex (decode)", {"op": "decode", "hex": hexs(ping) + "\u0000"}, {"error": "bad_hex"}))
    out.append(vec("NUL inside hex (parse)", {"op": "parse", "hex": hexs(ping) + "\u000000"}, {"error": "bad_hex"}))
    out.append(vec("NUL inside a chunk", {"op": "parse", "chunks": [hexs(ping), "\u0000"]}, {"error": "bad_hex"}))
    out.append(vec("NUL after the op", {"op": "decode\u0000", "hex": hexs(ping)}, {"error": "unknown_op"}))
    out.append(
        vec(
            "NUL in a field name",
            {"op": "encode", "id": 1, "message": "position_gains", **gains, "kp\u0000": 1},
            {"error": "unknown_field", "field": "kp\u0000"},
        )
    )
    out.append(
        vec(
            "NUL alone as a field name",
            {"op": "encode", "id": 0, "message": "request_ping", "\u0000": 1},
            {"error": "unknown_field", "field": "\u0000"},
        )
    )
    out.append(
        vec(
            "a field named __proto__",
            {"op": "encode", "id": 0, "message": "request_ping", "__proto__": 1},
            {"error": "unknown_field", "field": "__proto__"},
        )
    )
    out.append(
        vec(
            "a field named constructor",
            {"op": "encode", "id": 0, "message": "request_ping", "constructor": 1},
            {"error": "unknown_field", "field": "constructor"},
        )
    )
    out.append(
        vec("message named toString", {"op": "encode", "id": 0, "message": "toString"}, {"error": "unknown_message"})
    )
    out.append(
        vec("message named __proto__", {"op": "encode", "id": 0, "message": "__proto__"}, {"error": "unknown_message"})
    )
    out.append(vec("op named constructor", {"op": "constructor"}, {"error": "unknown_op"}))
    out.append(vec("unicode digits are not hex", {"op": "decode", "hex": "\u0661\u0662"}, {"error": "bad_hex"}))
    out.append(vec("full-width hex digits are not hex", {"op": "decode", "hex": "\uff46\uff46"}, {"error": "bad_hex"}))
    out.append(
        vec("hex with a trailing newline escape", {"op": "decode", "hex": hexs(ping) + "\n"}, {"error": "bad_hex"})
    )
    out.append(vec("upper-case hex", {"op": "decode", "hex": hexs(ping).upper()}, decoded_ping))

    # requests missing parts
    out.append(vec("no op", {"hex": hexs(ping)}, {"error": "unknown_op"}))
    out.append(vec("op not a string", {"op": 1}, {"error": "unknown_op"}))
    out.append(vec("op null", {"op": None}, {"error": "unknown_op"}))
    out.append(vec("op in upper case", {"op": "DECODE", "hex": hexs(ping)}, {"error": "unknown_op"}))
    out.append(vec("decode without hex", {"op": "decode"}, {"error": "bad_hex"}))
    out.append(vec("decode with hex null", {"op": "decode", "hex": None}, {"error": "bad_hex"}))
    out.append(vec("decode with hex a number", {"op": "decode", "hex": 12}, {"error": "bad_hex"}))
    out.append(vec("decode with hex a list", {"op": "decode", "hex": [hexs(ping)]}, {"error": "bad_hex"}))
    out.append(vec("message a number", {"op": "encode", "id": 0, "message": 160}, {"error": "unknown_message"}))
    out.append(vec("message null", {"op": "encode", "id": 0, "message": None}, {"error": "unknown_message"}))
    out.append(
        vec("id null", {"op": "encode", "id": None, "message": "request_ping"}, {"error": "type", "field": "id"})
    )
    out.append(
        vec("id true", {"op": "encode", "id": True, "message": "request_ping"}, {"error": "type", "field": "id"})
    )
    out.append(
        vec("id a list", {"op": "encode", "id": [1], "message": "request_ping"}, {"error": "type", "field": "id"})
    )
    out.append(
        vec(
            "field an object",
            {"op": "encode", "id": 1, "message": "position_gains", **dict(gains, kp={"v": 1})},
            {"error": "type", "field": "kp"},
        )
    )

    # chunks forms
    both = scan(ping + pos_ans)
    out.append(vec("chunks null: hex is the stream", {"op": "parse", "chunks": None, "hex": hexs(ping)}, scan(ping)))
    out.append(vec("chunks null and no hex", {"op": "parse", "chunks": None}, {"error": "bad_hex"}))
    out.append(
        vec("chunks given: hex is ignored", {"op": "parse", "chunks": [hexs(ping), hexs(pos_ans)], "hex": "zz"}, both)
    )
    out.append(vec("chunks empty list", {"op": "parse", "chunks": []}, {"frames": [], "dropped_bytes": 0}))
    out.append(vec("chunks of empty strings", {"op": "parse", "chunks": ["", hexs(ping), ""]}, scan(ping)))
    out.append(vec("chunks a string", {"op": "parse", "chunks": hexs(ping)}, {"error": "bad_hex"}))
    out.append(vec("chunks a number", {"op": "parse", "chunks": 3}, {"error": "bad_hex"}))
    out.append(vec("chunks an object", {"op": "parse", "chunks": {"0": hexs(ping)}}, {"error": "bad_hex"}))
    out.append(vec("chunks holding null", {"op": "parse", "chunks": [hexs(ping), None]}, {"error": "bad_hex"}))
    out.append(vec("chunks holding a number", {"op": "parse", "chunks": [12]}, {"error": "bad_hex"}))
    out.append(vec("chunks holding a list", {"op": "parse", "chunks": [[hexs(ping)]]}, {"error": "bad_hex"}))
    out.append(
        vec("chunks holding an odd-length chunk", {"op": "parse", "chunks": [hexs(ping), "f"]}, {"error": "bad_hex"})
    )
    out.append(vec("parse with neither hex nor chunks", {"op": "parse"}, {"error": "bad_hex"}))

    # nesting limit
    def nested(depth: int, *, close: bool = True) -> list[tuple[str, int]]:
        """A request object of `depth` levels: {"op":"teleport","x":[[...]]}."""
        inner = depth - 1
        return [('{"op":"teleport","x":', 1), ("[", inner), ("]" if close else "", inner), ("}" if close else "", 1)]

    out.append(
        line_vec(f"nesting {MAX_DEPTH} levels (the limit) is answered", nested(MAX_DEPTH), {"error": "unknown_op"})
    )
    out.append(line_vec(f"nesting {MAX_DEPTH + 1} levels", nested(MAX_DEPTH + 1), BAD_REQUEST))
    out.append(line_vec("nesting 1,000 levels", nested(1000), BAD_REQUEST))
    out.append(line_vec("nesting 100,000 levels", nested(100_000), BAD_REQUEST))
    out.append(line_vec("nesting 100,000 levels, never closed", nested(100_000, close=False), BAD_REQUEST))
    out.append(line_vec("100,000 nested arrays", [("[", 100_000), ("]", 100_000)], BAD_REQUEST))
    out.append(line_vec("100,000 nested objects", [('{"a":', 100_000), ("1", 1), ("}", 100_000)], BAD_REQUEST))
    out.append(
        line_vec(
            "nesting 100,000 levels inside chunks",
            [('{"op":"parse","chunks":', 1), ("[", 100_000), ("]", 100_000), ("}", 1)],
            BAD_REQUEST,
        )
    )

    # size limit
    padding = MAX_LINE_BYTES - len(decode_line)
    out.append(
        line_vec("a line of exactly 4 MiB is answered", [(decode_line[:-1], 1), (" ", padding), ("}", 1)], decoded_ans)
    )
    out.append(
        line_vec(
            "a line of 4 MiB + 1 byte is bad_request",
            [(decode_line[:-1], 1), (" ", padding + 1), ("}", 1)],
            BAD_REQUEST,
        )
    )
    out.append(
        line_vec(
            "a line of 4 MiB + 1 byte of hex",
            [('{"op":"parse","hex":"', 1), ("00", MAX_LINE_BYTES // 2), ('"}', 1)],
            BAD_REQUEST,
        )
    )
    out.append(line_vec("the line after an overlong line is read as usual", [(decode_line, 1)], decoded_ans))
    frames = 130_000
    expect = scan(ping * 3)
    assert expect == {"frames": [decoded_ping] * 3, "dropped_bytes": 0}
    many = {"frames": [{"$repeat": decoded_ping, "times": frames}], "dropped_bytes": 0}
    out.append(
        line_vec(
            f"parse {frames:,} frames in one hex string",
            [('{"op":"parse","hex":"', 1), (hexs(ping), frames), ('"}', 1)],
            many,
        )
    )
    out.append(
        line_vec(
            f"parse {frames:,} frames in {frames:,} chunks",
            [('{"op":"parse","chunks":["', 1), (hexs(ping) + '","', frames - 1), (hexs(ping) + '"]}', 1)],
            many,
        )
    )
    noisy = {"frames": [{"$repeat": decoded_ans, "times": 20_000}], "dropped_bytes": 3 * 20_000}
    assert scan((b"\xff\xfe\x00" + pos_ans) * 3) == {"frames": [decoded_ans] * 3, "dropped_bytes": 9}
    out.append(
        line_vec(
            "parse 20,000 frames each after a false header",
            [('{"op":"parse","hex":"', 1), ("fffe00" + hexs(pos_ans), 20_000), ('"}', 1)],
            noisy,
        )
    )
    return out


# ---- units: physical values <-> wire integers ------------------------------
#
# The reference rule (docs/protocol.md, conformance/README.md "units"): a JSON number is the
# double every JSON reader makes of it; its shortest decimal form (repr) is divided by the
# step exactly, in decimal, and rounded to the nearest integer, halves away from zero; the
# wire value is then range-checked. Wire -> physical is exact to the step's decimals.

SETTINGS_SPEC = json.loads((speclib.ROOT / "spec" / "settings.json").read_text())["settings"]
HOST_LIMITS = json.loads((speclib.ROOT / "spec" / "host.json").read_text())["limits"]


def field_of(message: str, name: str) -> dict[str, Any]:
    return next(f for f in MESSAGES[message]["fields"] if f["name"] == name)


def steps(value: float, scale: float) -> int:
    """Nearest step of `value` at `scale`, halves away from zero, on the decimal forms."""
    with localcontext() as ctx:
        ctx.prec = 800  # exact for every double
        exact = Decimal(repr(float(value))) / Decimal(repr(scale))
        return int(exact.quantize(Decimal(1), rounding=ROUND_HALF_UP))


def physical_of(raw: int, scale: float) -> float | int:
    exact = Decimal(raw) * Decimal(repr(scale))
    return int(exact) if exact == exact.to_integral_value() and scale >= 1 else float(exact)


def motion_quantity(name: str) -> dict[str, Any]:
    message, field, low, high = {
        "degrees": ("position_speed", "position", 0.0, HOST_LIMITS["position_deg"]),
        "rpm": ("accel_speed", "speed", HOST_LIMITS["speed_rpm_min"], HOST_LIMITS["speed_rpm_max"]),
        "seconds": ("accel_speed", "arrival_time", HOST_LIMITS["arrival_s_min"], HOST_LIMITS["arrival_s_max"]),
    }[name]
    scale = field_of(message, field)["scale"]
    return {"scale": scale, "min": steps(low, scale), "max": steps(high, scale), "signed": name != "seconds"}


def setting_quantity(name: str) -> dict[str, Any]:
    """A setting of spec/settings.json with the field (of its answer) that carries it."""
    entry = next(s for s in SETTINGS_SPEC if s["name"] == name)
    field = field_of(MESSAGES[entry["request"]]["answer"], entry["field"])
    values = {str(n): label for n, label in (field.get("values") or {}).items()}
    return {"field": field, "input": entry["input"], "values": values}


def ref_to_wire(quantity: str, value: Any) -> dict[str, Any]:
    """The answer to {"op":"to_wire"} (value as a Python number, or a string)."""
    motion = quantity in ("degrees", "rpm", "seconds")
    if not motion:
        s = setting_quantity(quantity)
        if isinstance(value, str):
            if s["input"] != "choice":
                return {"error": "type"}
            named = {label: int(n) for n, label in s["values"].items()}
            return {"wire": named[value]} if value in named else {"error": "range"}
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return {"error": "type"}
    number = float(value) if abs(value) < 1e300 else float("inf")
    if not math.isfinite(number):
        return {"error": "range"}
    if motion:
        q = motion_quantity(quantity)
        raw = steps(abs(number) if q["signed"] else number, q["scale"])
        if not q["min"] <= raw <= q["max"]:
            return {"error": "range"}
        return {"direction": int(number < 0), "wire": raw} if q["signed"] else {"wire": raw}
    field = s["field"]
    if s["input"] == "quantize":
        raw = steps(number, field["scale"])
    elif number.is_integer():
        raw = int(number)
    else:
        return {"error": "range"}
    return {"wire": raw} if field["min"] <= raw <= field["max"] else {"error": "range"}


def ref_from_wire(quantity: str, wire: int, direction: int = 0) -> dict[str, Any]:
    if quantity in ("degrees", "rpm", "seconds"):
        value = physical_of(wire, motion_quantity(quantity)["scale"])
        # zero has no sign: direction 1 with wire 0 is 0, never -0.0 (conformance/README.md)
        return {"value": -value if direction == 1 and quantity != "seconds" and value else value}
    s = setting_quantity(quantity)
    if str(wire) in s["values"]:
        return {"value": s["values"][str(wire)]}
    return {"value": physical_of(wire, s["field"]["scale"])}


def to_wire_vec(name: str, quantity: str, value: Any) -> dict[str, Any]:
    return vec(name, {"op": "to_wire", "quantity": quantity, "value": value}, ref_to_wire(quantity, value))


def units_vectors() -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    quantize = ["degrees", "rpm", "seconds"] + [s["name"] for s in SETTINGS_SPEC if s["input"] == "quantize"]
    for quantity in quantize:
        if quantity in ("degrees", "rpm", "seconds"):
            q = motion_quantity(quantity)
            scale, low, high = q["scale"], q["min"], q["max"]
        else:
            field = setting_quantity(quantity)["field"]
            scale, low, high = field["scale"], field["min"], field["max"]
        step = Decimal(repr(scale))
        top = Decimal(high) * step
        bottom = Decimal(low) * step
        edges: list[tuple[str, Any]] = [
            ("the smallest", float(bottom) if scale < 1 else int(bottom)),
            ("the largest", float(top) if scale < 1 else int(top)),
            ("the largest + a shade under half a step", float(top + step * Decimal("0.49"))),
            ("the largest + half a step", float(top + step / 2)),
            ("the smallest - half a step", float(bottom - step / 2)),
            ("the smallest - a shade over half a step", float(bottom - step * Decimal("0.51"))),
            ("a typical value", float((bottom + top) / 2)),
            ("zero", 0),
            ("zero written 0.0", 0.0),
            ("-0.0", -0.0),
            ("a tiny value", 1e-7),
            ("1e30", 1e30),
            ("a 30-digit integer", 10**30),
            ("-1", -1),
        ]
        # halves of the step in decimal that are just below the half in binary, and the other way
        halves = [(Decimal(k) + Decimal("0.5")) * step for k in (0, 1, 2, 7, 1800, 12344) if k < high]
        traps = ("0.15", "0.25", "0.35", "1.005", "2.675", "180.005", "0.285", "1.115", "12.345", "250")
        for text in [*traps, *(str(h.normalize()) for h in halves)]:
            edges.append((f"{text}", float(text) if "." in text or "E" in text else int(text)))
            edges.append((f"-{text}", -float(text) if "." in text or "E" in text else -int(text)))
        edges += [("0.14999 (below a half)", 0.14999), ("0.15001 (above a half)", 0.15001)]
        for label, value in edges:
            out.append(to_wire_vec(f"to_wire {quantity}: {label}", quantity, value))
        for text in ("1e400", "-1e400", "1e-400", "1.8e2", "5E-2", "-0"):
            value = float(text) if text != "-0" else 0
            expect = ref_to_wire(quantity, value)
            out.append(
                line_vec(
                    f"to_wire {quantity}: written {text}",
                    [(f'{{"op":"to_wire","quantity":"{quantity}","value":{text}}}', 1)],
                    expect,
                )
            )
        # every wire value round-trips through its physical value (a seeded sample)
        rng = random.Random(f"units {quantity}")
        for raw in sorted({low, high, *rng.sample(range(low, high + 1), min(12, high - low + 1))}):
            physical = ref_from_wire(quantity, raw)["value"]
            out.append(to_wire_vec(f"to_wire {quantity}: {physical} is wire {raw}", quantity, physical))
        for index in range(12):
            value = round(rng.uniform(-1.2, 1.2) * float(top), rng.choice([1, 2, 3, 4, 7]))
            out.append(to_wire_vec(f"to_wire {quantity}: random value {index}", quantity, value))
    # whole-number settings: a fraction is refused, a whole number written as a float is not
    for s in SETTINGS_SPEC:
        if s["input"] != "integer":
            continue
        field = setting_quantity(s["name"])["field"]
        for label, value in [
            ("the smallest", field["min"]),
            ("the largest", field["max"]),
            ("below the smallest", field["min"] - 1),
            ("above the largest", field["max"] + 1),
            ("a fraction", field["min"] + 0.5),
            ("a small fraction", field["max"] - 0.001),
            ("a whole number written 2.0", 2.0),
        ]:
            out.append(to_wire_vec(f"to_wire {s['name']}: {label}", s["name"], value))
        out.append(
            line_vec(
                f"to_wire {s['name']}: a whole number written 1e1",
                [(f'{{"op":"to_wire","quantity":"{s["name"]}","value":1e1}}', 1)],
                ref_to_wire(s["name"], 10.0),
            )
        )
    # choices: a value name or the wire integer
    for s in SETTINGS_SPEC:
        if s["input"] != "choice":
            continue
        values = setting_quantity(s["name"])["values"]
        for n, label in values.items():
            out.append(to_wire_vec(f"to_wire {s['name']}: {label}", s["name"], label))
            out.append(to_wire_vec(f"to_wire {s['name']}: {n}", s["name"], int(n)))
        for value in ["sideways", "", 2, 0.5, -1]:
            out.append(to_wire_vec(f"to_wire {s['name']}: {value!r}", s["name"], value))
    # what is not a value, and what is not a quantity
    for label, value in [("null", None), ("true", True), ("a list", [1]), ("an object", {"v": 1}), ("a string", "90")]:
        out.append(to_wire_vec(f"to_wire degrees: value {label}", "degrees", value))
        out.append(to_wire_vec(f"to_wire ratio: value {label}", "ratio", value))
    out.append(vec("to_wire without a value", {"op": "to_wire", "quantity": "rpm"}, {"error": "type"}))
    out.append(vec("to_wire rpm: 0 is no speed", {"op": "to_wire", "quantity": "rpm", "value": 0}, {"error": "range"}))
    for quantity in ["furlongs", "Degrees", "position_kp", "", 3, None, "degrees\u0000"]:
        out.append(
            vec(
                f"to_wire: quantity {quantity!r} is unknown",
                {"op": "to_wire", "quantity": quantity, "value": 1},
                {"error": "unknown_quantity"},
            )
        )
    out.append(vec("to_wire without a quantity", {"op": "to_wire", "value": 1}, {"error": "unknown_quantity"}))
    # wire -> physical
    everything = ["degrees", "rpm", "seconds"] + [s["name"] for s in SETTINGS_SPEC]
    for quantity in everything:
        rng = random.Random(f"from_wire {quantity}")
        wires = [0, 1, 3, 255, 18001, 65533, 65535, rng.randrange(65536), rng.randrange(256)]
        for wire in wires:
            directions = [0, 1] if quantity in ("degrees", "rpm") else [None]
            for direction in directions:
                request: dict[str, Any] = {"op": "from_wire", "quantity": quantity, "wire": wire}
                if direction is not None:
                    request["direction"] = direction
                name = f"from_wire {quantity}: {wire}" + ("" if direction is None else f" direction {direction}")
                out.append(vec(name, request, ref_from_wire(quantity, wire, direction or 0)))
    for label, request, expect in [
        ("wire 65536", {"quantity": "ratio", "wire": 65536}, {"error": "range"}),
        ("wire -1", {"quantity": "ratio", "wire": -1}, {"error": "range"}),
        ("a 30-digit wire", {"quantity": "ratio", "wire": 10**30}, {"error": "range"}),
        ("wire a string", {"quantity": "ratio", "wire": "125"}, {"error": "type"}),
        ("wire null", {"quantity": "ratio", "wire": None}, {"error": "type"}),
        ("no wire", {"quantity": "ratio"}, {"error": "type"}),
        ("direction 2", {"quantity": "degrees", "wire": 5, "direction": 2}, {"error": "range"}),
        ("no direction", {"quantity": "degrees", "wire": 5}, {"error": "type"}),
        ("direction true", {"quantity": "rpm", "wire": 5, "direction": True}, {"error": "type"}),
        ("unknown quantity", {"quantity": "furlongs", "wire": 5}, {"error": "unknown_quantity"}),
    ]:
        out.append(vec(f"from_wire: {label}", {"op": "from_wire", **request}, expect))
    for text in ("125.0", "1e2", "-0.0"):
        out.append(
            line_vec(
                f"from_wire: wire written {text} is no integer",
                [(f'{{"op":"from_wire","quantity":"ratio","wire":{text}}}', 1)],
                {"error": "type"},
            )
        )
    return out


# ---- product lines (spec/lines.json) ---------------------------------------
#
# A request may name a `line` (default "mc"); the line's mode table decides what a mode byte
# means and which messages exist. The reference model below reads each line's table only.

LINES = SPEC["lines"]


def line_messages(line: str) -> dict[str, dict[str, Any]]:
    return {m["name"]: m for m in LINES[line]["messages"]}


def line_encode(line: str, name: str, msg_id: int, fields: dict[str, int]) -> bytes:
    msg = line_messages(line)[name]
    data = b"".join(fields[f["name"]].to_bytes(f["width"], "big") for f in msg["fields"])
    return frame(msg_id, msg["mode"], data)


def line_decode(line: str, raw: bytes) -> dict[str, Any]:
    """decode() with the line's mode table (the same checks in the same order)."""
    if raw[:2] != HEADER[: len(raw[:2])]:
        return {"error": "header"}
    if len(raw) < 6 or len(raw) < raw[3] + 4:
        return {"error": "truncated"}
    if len(raw) > raw[3] + 4:
        return {"error": "trailing"}
    if ~sum(raw[2:4] + raw[5:]) & 0xFF != raw[4]:
        return {"error": "checksum"}
    msg = next((m for m in LINES[line]["messages"] if m["mode"] == raw[5]), None)
    if msg is None:
        return {"error": "unknown_mode"}
    if raw[3] != msg["size"]:
        return {"error": "size"}
    out: dict[str, Any] = {"id": raw[2], "message": msg["name"]}
    offset = 6
    for f in msg["fields"]:
        out[f["name"]] = int.from_bytes(raw[offset : offset + f["width"]], "big")
        offset += f["width"]
    return out


def line_scan(line: str, stream: bytes) -> dict[str, Any]:
    frames, dropped, pos = [], 0, 0
    while pos < len(stream):
        size = stream[pos + 3] if pos + 3 < len(stream) else 0
        candidate = stream[pos : pos + size + 4]
        result = line_decode(line, candidate) if len(candidate) >= 6 else {"error": "truncated"}
        if "error" in result:
            dropped += 1
            pos += 1
        else:
            frames.append(result)
            pos += len(candidate)
    return {"frames": frames, "dropped_bytes": dropped}


# Frames written out by hand from the fact sheet's layouts (product-lines.md §3-§4), checked
# against the model: (line, hex, message, id, fields).
VENDOR_FRAMES: list[tuple[str, str, str, int, dict[str, int]]] = [
    ("rsa", "FF FE 00 04 E8 09 00 0A", "set_ratio", 0, {"ratio": 10}),
    ("rsa", "FF FE 01 03 F0 0B 00", "set_position_mode", 1, {"position_mode": 0}),
    ("rsa", "FF FE 00 03 F1 0A 01", "set_control", 0, {"control": 1}),
    (
        "rsa",
        "FF FE 00 07 76 01 00 46 50 03 E8",
        "position_speed",
        0,
        {"direction": 0, "position": 18000, "speed": 1000},
    ),
    ("rsa", "FF FE 00 02 57 A6", "request_ratio", 0, {}),
    ("rsa", "FF FE 00 04 C1 D6 00 64", "ratio", 0, {"ratio": 100}),
    ("rsa", "FF FE 00 03 24 D8 00", "position_mode", 0, {"position_mode": 0}),
    ("rsa", "FF FE 00 03 25 D7 00", "control", 0, {"control": 0}),
    ("rsavw", "FF FE 00 03 ED 0E 01", "set_echo", 0, {"echo": 1}),
    ("rsavw", "FF FE 00 02 54 A9", "request_absolute_position", 0, {}),
    ("rsavw", "FF FE 02 05 F2 D9 01 8C A0", "absolute_position", 2, {"direction": 1, "absolute_position": 36000}),
    ("rsavw", "FF FE 00 03 21 DA 01", "echo", 0, {"echo": 1}),
    ("sa", "FF FE 00 05 4E 11 00 13 88", "open_loop", 0, {"direction": 0, "duty": 5000}),
    ("sm", "FF FE 00 03 F4 07 01", "set_control", 0, {"control": 1}),
    ("sm", "FF FE 00 04 EB 06 00 0A", "set_ratio", 0, {"ratio": 10}),
    ("sm", "FF FE 00 02 F5 08", "reset_position", 0, {}),
    (
        "sm",
        "FF FE 07 08 91 D1 01 03 E8 00 96 0C",
        "speed_feedback",
        7,
        {"direction": 1, "speed": 1000, "position": 150, "current": 12},
    ),
    ("sm", "FF FE 00 06 CD D2 1E 0A 00 32", "speed_gains", 0, {"kp": 30, "ki": 10, "kd": 0, "rated_current": 50}),
    ("sm", "FF FE 00 04 1D D4 00 0A", "ratio", 0, {"ratio": 10}),
    ("sm", "FF FE 00 03 27 D5 00", "control", 0, {"control": 0}),
    ("sm-cs", "FF FE 00 06 0C 01 00 03 E8 01", "accel_speed", 0, {"direction": 0, "speed": 1000, "arrival_time": 1}),
    ("sm-cs", "FF FE 00 03 F8 03 01", "set_id", 0, {"new_id": 1}),
    (
        "sm-cs",
        "FF FE 00 06 9D 02 1E 0A 00 32",
        "set_speed_gains",
        0,
        {"kp": 30, "ki": 10, "kd": 0, "rated_current": 50},
    ),
    (
        "sm-readme",
        "FF FE 00 06 0A 03 00 03 E8 01",
        "accel_speed",
        0,
        {"direction": 0, "speed": 1000, "arrival_time": 1},
    ),
    ("sm-readme", "FF FE 00 03 21 D6 05", "firmware_a6", 0, {"version": 5}),
]


def with_line(line: str, request: dict[str, Any]) -> dict[str, Any]:
    return {**request, "line": line}


def lines_vectors() -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for line, printed, name, msg_id, fields in VENDOR_FRAMES:
        raw = unspaced(printed)
        expected = {"id": msg_id, "message": name, **fields}
        assert line_decode(line, raw) == expected, (line, printed)
        assert line_encode(line, name, msg_id, fields) == raw, (line, printed)
        tag = f"{line} vendor layout {printed}"
        out.append(vec(tag + ": decode", {"op": "decode", "hex": hexs(raw), "line": line}, expected))
        out.append(vec(tag + ": encode", with_line(line, encode_request(name, msg_id, fields)), {"hex": hexs(raw)}))
    for line, entry in LINES.items():
        for msg in entry["messages"]:
            name, fields = msg["name"], msg["fields"]
            cases = {
                "min": (0, {f["name"]: f["min"] for f in fields}),
                "max": (msg["max_id"], {f["name"]: f["max"] for f in fields}),
                "typical": (17, {f["name"]: typical(f) for f in fields}),
            }
            if line == "mc":  # messages.jsonl has MC in full: here only that "line":"mc" is MC
                cases = {"typical": cases["typical"]}
            for case, (msg_id, values) in cases.items():
                raw = line_encode(line, name, msg_id, values)
                tag = f"{line} {name} {case}"
                out.append(
                    vec(tag + ": encode", with_line(line, encode_request(name, msg_id, values)), {"hex": hexs(raw)})
                )
                out.append(
                    vec(tag + ": decode", {"op": "decode", "hex": hexs(raw), "line": line}, line_decode(line, raw))
                )
            if line == "mc":
                continue
            typical_values = cases["typical"][1]
            for f in fields:
                for bad in (f["min"] - 1, f["max"] + 1):
                    if 0 <= bad < (1 << 8 * f["width"]) and f["min"] <= bad <= f["max"]:
                        continue
                    values = dict(typical_values, **{f["name"]: bad})
                    out.append(
                        vec(
                            f"{line} {name}.{f['name']} = {bad} out of range",
                            with_line(line, encode_request(name, 1, values)),
                            {"error": "range", "field": f["name"]},
                        )
                    )
            if msg["kind"] != "command":
                out.append(
                    vec(
                        f"{line} {name} id 255 is broadcast, not allowed",
                        with_line(line, encode_request(name, 0xFF, typical_values)),
                        {"error": "range", "field": "id"},
                    )
                )
    # a message belongs to a line: names another line has are unknown here
    every = {m["name"] for entry in LINES.values() for m in entry["messages"]}
    for line, entry in LINES.items():
        own = {m["name"] for m in entry["messages"]}
        for name in sorted(every - own):
            out.append(
                vec(
                    f"{line} has no {name}",
                    {"op": "encode", "id": 0, "message": name, "line": line},
                    {"error": "unknown_message"},
                )
            )
    # one frame, a different message per line (the point of lines): every line decodes every
    # line's typical frame of every mode its own way (or not at all)
    seen: set[bytes] = set()
    for entry in LINES.values():
        for msg in entry["messages"]:
            raw = line_encode(entry["key"], msg["name"], 3, {f["name"]: typical(f) for f in msg["fields"]})
            if raw in seen:
                continue
            seen.add(raw)
            for line in LINES:
                out.append(
                    vec(
                        f"{line} reads {raw.hex(' ')}",
                        {"op": "decode", "hex": hexs(raw), "line": line},
                        line_decode(line, raw),
                    )
                )
    # streams in a line's terms
    rng = random.Random("lines")
    for line, entry in LINES.items():
        if line == "mc":
            continue
        frames = [
            line_encode(line, m["name"], rng.randrange(255), {f["name"]: typical(f) for f in m["fields"]})
            for m in entry["messages"]
        ]
        stream = b"".join(frames) + b"\xff\xfe\x00"
        cut = len(stream) // 3
        out.append(
            vec(
                f"{line} stream of every message",
                {"op": "parse", "chunks": [hexs(stream[:cut]), hexs(stream[cut:])], "line": line},
                line_scan(line, stream),
            )
        )
    # what is no line
    for bad in ["MC", "rsa ", "", "blmc-h", "sm_cs", 3, None, True]:
        for op in (
            {"op": "decode", "hex": "fffe00025fa0"},
            {"op": "encode", "id": 0, "message": "request_ping"},
            {"op": "parse", "hex": ""},
        ):
            out.append(vec(f"{op['op']}: line {bad!r} is unknown", {**op, "line": bad}, {"error": "unknown_line"}))
    return out


SETS = {
    "lines": lines_vectors,
    "examples": example_vectors,
    "errata": errata_vectors,
    "messages": message_vectors,
    "broken": broken_vectors,
    "streams": stream_vectors,
    "edges": edge_vectors,
    "units": units_vectors,
}


def main() -> int:
    check = "--check" in sys.argv[1:]
    stale = []
    for name, make in SETS.items():
        text = "".join(json.dumps(v, ensure_ascii=False) + "\n" for v in make())
        if speclib.write_if_changed(OUT / f"{name}.jsonl", text, check):
            stale.append(name)
    if check and stale:
        print(f"stale vectors: {', '.join(stale)}; run: python3 tools/make_vectors.py", file=sys.stderr)
        return 1
    if not check:
        print(f"vectors written to {OUT.relative_to(speclib.ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
