"""A CLI command on a port another nurimc program holds: attached to it (docs/service.md)."""

from __future__ import annotations

import sys
import threading
import time
from typing import Any

from ..drivers.sync import Bus
from ..errors import NurimcError
from ..procedures.motor import MotorState
from ..service.share import AttachedBus, HolderGone, connect, shareable
from .i18n import tr


def say_line(text: str) -> None:
    """One line on stderr in the language in use (as common.say_line; common imports this module)."""
    print(tr(text), file=sys.stderr, flush=True)


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
    if not shareable(port):  # sim:// and loop:// are a bus of each process alone
        return None
    conn = connect(port, program, _said)
    if conn is None:
        return None
    return AttachedBus(conn, port, baud, tracer=tracer)


class SharedReadings:
    """Readings of some motors from the holder's shared poll schedule (docs/service.md): an
    attached `watch` or `record` adds no reads of its own to a bus the holder reads anyway."""

    def __init__(self, bus: AttachedBus, ids: list[int], rate_hz: float) -> None:
        self._lock = threading.Lock()
        self._fresh = threading.Event()
        self._latest: dict[int, MotorState | NurimcError] = {}
        self._new: dict[int, MotorState | NurimcError] = {}
        self.bus = bus
        self.count = len(set(ids))
        bus.subscribe(ids, rate_hz, self._sample)
        self.take(1.0)  # the first round (kept as the latest), so a first table is not empty

    def _sample(self, sample: dict[str, Any]) -> None:
        state = sample.get("state")
        value: MotorState | NurimcError = (
            MotorState(id=int(sample["id"]), **state) if state else NurimcError(str(sample.get("error") or "no answer"))
        )
        with self._lock:
            self._latest[value.id if isinstance(value, MotorState) else int(sample["id"])] = value
            self._new[int(sample["id"])] = value
        self._fresh.set()

    def latest(self) -> dict[int, MotorState | NurimcError]:
        """The last reading of each motor (or why it failed)."""
        if self.bus.conn.gone is not None:
            raise HolderGone(f"{self.bus.conn.gone}; run the command again (it opens the port itself now)")
        with self._lock:
            return dict(self._latest)

    def take(self, timeout: float) -> dict[int, MotorState | NurimcError]:
        """The readings that came since the last take: waits until every motor has a new one
        (one round of the holder's readings), or `timeout`."""
        end = time.monotonic() + timeout
        while len(self._new) < self.count and time.monotonic() < end:
            self._fresh.wait(max(0.0, end - time.monotonic()))
            self._fresh.clear()
        if self.bus.conn.gone is not None:
            raise HolderGone(f"{self.bus.conn.gone}; run the command again (it opens the port itself now)")
        with self._lock:
            new, self._new = self._new, {}
            self._fresh.clear()
        return new
