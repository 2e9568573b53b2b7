"""A CLI command on a port another nurimc program holds: attached to it (docs/service.md)."""

from __future__ import annotations

from typing import Any

from ..client.sync import Bus
from ..service.share import AttachedBus, connect
from .common import say_line


def _said(event: dict[str, Any]) -> None:
    """What the holder tells every attached program, said on stderr."""
    kind = event.get("type")
    if kind == "closed":
        say_line(str(event.get("message")))
    elif kind == "estop":
        stopped = ", ".join(map(str, event.get("stopped", []))) or "none"
        missing = ", ".join(map(str, event.get("not_confirmed", [])))
        say_line(
            f"emergency stop on the shared bus: ID {stopped} read back off"
            + (f"; NOT confirmed: ID {missing}" if missing else "")
        )


def attached_bus(port: str, baud: int, tracer: Any, command: str = "") -> Bus | None:
    """An AttachedBus when a live nurimc program holds `port`, else None (open it yourself)."""
    program = f"nurimc {command}".strip()
    conn = connect(port, program, _said)
    if conn is None:
        return None
    return AttachedBus(conn, port, baud, tracer=tracer)
