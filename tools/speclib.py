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
LINES_PATH = ROOT / "spec" / "lines.json"
WIDTHS = {"u8": 1, "u16": 2}


def _int(value: Any) -> int:
    return int(value, 16) if isinstance(value, str) else int(value)


def _resolve(msg: dict[str, Any], fields: dict[str, Any], frame: dict[str, Any]) -> None:
    """Resolve a message's field references in place (and its largest ID)."""
    resolved = []
    for ref in msg["fields"]:
        override = {"name": ref} if isinstance(ref, str) else dict(ref)
        field = dict(fields[override["name"]])
        field.update(override)
        field.setdefault("unit", "")
        field.setdefault("scale", 1)
        field["width"] = WIDTHS[field["type"]]
        resolved.append(field)
    msg["fields"] = resolved
    msg["max_id"] = frame["broadcast_id"] if msg["kind"] == "command" else frame["max_device_id"]
    if 2 + sum(f["width"] for f in resolved) != msg["size"]:
        raise SystemExit(f"spec: {msg['name']} size {msg['size']} does not match its fields")


def load() -> dict[str, Any]:
    """The spec with hex strings as ints and every message's fields resolved.

    `spec["lines"]` holds every product line of spec/lines.json: its title and facts, and
    `messages`, the line's message dicts (same shape as spec["messages"]; MC's are those).
    """
    spec: dict[str, Any] = json.loads(SPEC_PATH.read_text())
    frame = spec["frame"]
    frame["header"] = [_int(b) for b in frame["header"]]
    frame["broadcast_id"] = _int(frame["broadcast_id"])
    frame["max_device_id"] = _int(frame["max_device_id"])
    for msg in spec["messages"]:
        msg["mode"] = _int(msg["mode"])
        _resolve(msg, spec["fields"], frame)
    lines_data = json.loads(LINES_PATH.read_text())
    spec["lines"] = _lines(spec, lines_data)
    spec["product_lines"] = {k: v for k, v in lines_data["product_lines"].items() if not k.startswith("$")}
    named = set(spec["product_lines"].values())
    if set(spec["product_lines"]) != set(spec["products"]) or not named <= set(spec["lines"]):
        raise SystemExit("spec/lines.json product_lines must name every product of spec/protocol.json and a line each")
    return spec


def _line_message(
    spec: dict[str, Any], data: dict[str, Any], fields: dict[str, Any], name: str, mode: int
) -> dict[str, Any]:
    """A line's message: MC's layout of that name, or one of lines.json's own layouts."""
    mc = {m["name"]: m for m in spec["messages"]}
    if name in mc:
        base = mc[name]
        msg = {k: v for k, v in base.items() if k not in ("fields", "mode", "section", "max_id")}
        msg["fields"] = [dict(f) for f in base["fields"]]
        msg["max_id"] = base["max_id"]
    else:
        msg = dict(data["layouts"][name], name=name)
        _resolve(msg, fields, spec["frame"])
    msg["mode"] = mode
    msg["section"] = 0
    return msg


def _lines(spec: dict[str, Any], data: dict[str, Any]) -> dict[str, Any]:
    """Each line with its messages resolved: MC's layouts by name, or the extra layouts."""
    fields = {**spec["fields"], **data["fields"]}
    lines: dict[str, Any] = {}
    for key, entry in data["lines"].items():
        line = {k: v for k, v in entry.items() if k not in ("modes", "base", "messages")}
        line["key"] = key
        if entry.get("messages") == "spec/protocol.json":
            line["messages"] = spec["messages"]
            lines[key] = line
            continue
        modes = dict(lines[entry["base"]]["modes"]) if "base" in entry else {}
        modes.update({name: _int(mode) for name, mode in entry["modes"].items()})
        line["modes"] = modes
        messages = [_line_message(spec, data, fields, name, mode) for name, mode in modes.items()]
        # a request's answer is in the line at mode + 0x30 (the rule of every line, S1 enums)
        messages += [
            _line_message(spec, data, fields, m["answer"], (m["mode"] + 0x30) & 0xFF)
            for m in messages
            if m.get("answer")
        ]
        if len({m["mode"] for m in messages}) != len(messages) or len({m["name"] for m in messages}) != len(messages):
            raise SystemExit(f"spec/lines.json: line {key} gives two messages one mode or one name twice")
        messages.sort(key=lambda m: (("command", "request", "answer").index(m["kind"]), m["mode"]))
        line["messages"] = messages
        lines[key] = line
    return lines


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
