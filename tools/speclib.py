"""Load spec/protocol.json for the generators (stdlib only; no project code).

The generators and the vector maker read the spec through this module so that
hex strings and field overrides are resolved in exactly one place.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
SPEC_PATH = ROOT / "spec" / "protocol.json"
WIDTHS = {"u8": 1, "u16": 2}


def _int(value: Any) -> int:
    return int(value, 16) if isinstance(value, str) else int(value)


def load() -> dict[str, Any]:
    """The spec with hex strings as ints and every message's fields resolved."""
    spec: dict[str, Any] = json.loads(SPEC_PATH.read_text())
    frame = spec["frame"]
    frame["header"] = [_int(b) for b in frame["header"]]
    frame["broadcast_id"] = _int(frame["broadcast_id"])
    frame["max_device_id"] = _int(frame["max_device_id"])
    for msg in spec["messages"]:
        msg["mode"] = _int(msg["mode"])
        resolved = []
        for ref in msg["fields"]:
            override = {"name": ref} if isinstance(ref, str) else dict(ref)
            field = dict(spec["fields"][override["name"]])
            field.update(override)
            field.setdefault("unit", "")
            field.setdefault("scale", 1)
            field["width"] = WIDTHS[field["type"]]
            resolved.append(field)
        msg["fields"] = resolved
        msg["max_id"] = frame["broadcast_id"] if msg["kind"] == "command" else frame["max_device_id"]
        if 2 + sum(f["width"] for f in resolved) != msg["size"]:
            raise SystemExit(f"spec: {msg['name']} size {msg['size']} does not match its fields")
    return spec


def camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def write_if_changed(path: Path, text: str, check: bool) -> bool:
    """Write text to path; with check, only report whether it is stale. True = stale."""
    old = path.read_text() if path.exists() else None
    if old == text:
        return False
    if not check:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return True
