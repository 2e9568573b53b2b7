"""`nurimc demo`: the main job."""

from __future__ import annotations

import json
from importlib import resources

from rich.console import Console
from rich.table import Table

from ..protocol import decode
from .app import app


@app.command()
def demo() -> None:
    """Decode and re-encode every worked example of the protocol document."""
    console = Console()
    spec = json.loads(resources.files("nurimc").joinpath("../../../spec/protocol.json").read_text())
    table = Table(title="MC-RS485 V1.0.1: the document's examples, decoded and re-encoded")
    for column in ("§", "frame", "decoded", "round trip"):
        table.add_column(column)
    for ex in spec["examples"]:
        raw = bytes.fromhex(ex["hex"])
        message = decode(raw)
        ok = message.encode() == raw
        table.add_row(str(ex["section"]), ex["hex"], f"{message.name} {message.physical()}", "ok" if ok else "FAIL")
    console.print(table)
