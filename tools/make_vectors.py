#!/usr/bin/env python3
"""Write the conformance vectors in spec/vectors/ from spec/protocol.json.

The expected answers come from the small reference model in this file (frame
building, the whole-frame checks, and the stream rule stated in
conformance/README.md), written from the document and independent of every
language implementation. `--check` fails when the committed vectors are stale.

Usage: python3 tools/make_vectors.py [--check]
"""

from __future__ import annotations

import json
import random
import sys
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
            out.append(vec(f"{name} broadcast: encode", encode_request(name, 0xFF, cases["typical"]), {"hex": hexs(raw)}))
            out.append(vec(f"{name} broadcast: decode", {"op": "decode", "hex": hexs(raw)}, decode(raw)))
        else:
            out.append(vec(f"{name} id 255 is broadcast, not allowed", encode_request(name, 0xFF, cases["typical"]), {"error": "range", "field": "id"}))
        out.append(vec(f"{name} id 256", encode_request(name, 256, cases["typical"]), {"error": "range", "field": "id"}))
        out.append(vec(f"{name} id -1", encode_request(name, -1, cases["typical"]), {"error": "range", "field": "id"}))
        for f in fields:
            for bad in (f["min"] - 1, f["max"] + 1, 1 << (8 * f["width"])):
                if 0 <= bad < (1 << 8 * f["width"]) and f["min"] <= bad <= f["max"]:
                    continue
                values = dict(cases["typical"], **{f["name"]: bad})
                out.append(vec(f"{name}.{f['name']} = {bad} out of range", encode_request(name, 1, values), {"error": "range", "field": f["name"]}))
            values = dict(cases["typical"])
            del values[f["name"]]
            out.append(vec(f"{name} without {f['name']}", encode_request(name, 1, values), {"error": "missing_field", "field": f["name"]}))
            for wrong in ("12", 1.5, True, None):
                values = dict(cases["typical"], **{f["name"]: wrong})
                out.append(vec(f"{name}.{f['name']} = {wrong!r} is not an integer", encode_request(name, 1, values), {"error": "type", "field": f["name"]}))
        if fields:
            # Out-of-range values in an otherwise valid frame decode as they are.
            values = {f["name"]: (1 << 8 * f["width"]) - 1 for f in fields}
            raw = encode(name, 3, values)
            out.append(vec(f"{name} with every field 0xFF..: decode as is", {"op": "decode", "hex": hexs(raw)}, decode(raw)))
        values = dict(cases["typical"], bogus=1)
        out.append(vec(f"{name} with an unknown field", encode_request(name, 1, values), {"error": "unknown_field", "field": "bogus"}))
    out.append(vec("unknown message", {"op": "encode", "id": 0, "message": "warp_drive"}, {"error": "unknown_message"}))
    out.append(vec("message missing", {"op": "encode", "id": 0}, {"error": "missing_field", "field": "message"}))
    out.append(vec("id missing", {"op": "encode", "message": "request_ping"}, {"error": "missing_field", "field": "id"}))
    out.append(vec("id not an integer", {"op": "encode", "id": "0", "message": "request_ping"}, {"error": "type", "field": "id"}))
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
                parts.append(bytes(rng.choice([0xFF, 0xFE, 0x00, rng.randrange(256)]) for _ in range(rng.randint(1, 9))))
        stream = b"".join(parts)
        cuts = sorted(rng.sample(range(1, len(stream)), min(3, len(stream) - 1))) if len(stream) > 1 else []
        bounds = [0, *cuts, len(stream)]
        add(f"random mix {i}", stream, [stream[a:b] for a, b in zip(bounds, bounds[1:])])
    for i in range(4):
        noise = bytes(rng.randrange(256) for _ in range(64))
        add(f"random noise {i}", noise)
    return out


SETS = {
    "examples": example_vectors,
    "errata": errata_vectors,
    "messages": message_vectors,
    "broken": broken_vectors,
    "streams": stream_vectors,
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
