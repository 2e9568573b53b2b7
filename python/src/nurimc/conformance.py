"""The JSON-lines conformance program (conformance/README.md): one answer line per input line."""

from __future__ import annotations

import json
import re
import sys
from typing import Any, TextIO

from .protocol import DecodeError, EncodeError, StreamParser, decode, make

_HEX = re.compile(r"(?:[0-9a-fA-F]{2})*")


def _bytes(text: object) -> bytes:
    """Contiguous hex digit pairs, either case; anything else is `bad_hex` (a ValueError)."""
    if not isinstance(text, str) or not _HEX.fullmatch(text):
        raise ValueError(f"not hex: {text!r}")
    return bytes.fromhex(text)


def answer(request: Any) -> dict[str, Any]:
    if not isinstance(request, dict):
        return {"error": "bad_request", "detail": "each line must be a JSON object"}
    op = request.get("op")
    try:
        if op == "decode":
            return decode(_bytes(request.get("hex"))).to_dict()
        if op == "encode":
            fields = {k: v for k, v in request.items() if k not in ("op", "id", "message")}
            for key in ("message", "id"):
                if key not in request:
                    return {"error": "missing_field", "field": key}
            if not isinstance(request["message"], str):
                return {"error": "unknown_message"}
            return {"hex": make(request["message"], request["id"], **fields).encode().hex()}
        if op == "parse":
            chunks = request.get("chunks")
            parser = StreamParser()
            frames = []
            if chunks is None:
                frames += parser.feed(_bytes(request.get("hex")))
            else:
                for chunk in chunks if isinstance(chunks, list) else [None]:
                    frames += parser.feed(_bytes(chunk))
            frames += parser.finish()
            return {"frames": [m.to_dict() for m in frames], "dropped_bytes": parser.stats.dropped_bytes}
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


def serve(stdin: TextIO = sys.stdin, stdout: TextIO = sys.stdout) -> None:
    for line in stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
        except json.JSONDecodeError as err:
            reply: dict[str, Any] = {"error": "bad_request", "detail": f"not JSON: {err}"}
        else:
            reply = answer(request)
        stdout.write(json.dumps(reply) + "\n")
        stdout.flush()


if __name__ == "__main__":
    serve()
