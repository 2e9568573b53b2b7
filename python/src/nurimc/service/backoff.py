"""Motors that stop answering are read less often (docs/service.md): the rule of the bus
service's poll schedule, as a small object the programs that still poll on their own (the
console's worker) share, so a dead motor never costs the others their rate."""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any

from ..procedures.motor import MotorProcedures, MotorState

SILENT_AFTER = 2  # failed reads in a row before a motor is "not answering" (one lost frame is not)
BACKOFF_FIRST = 0.1  # s before the first retry of a motor that does not answer
BACKOFF_MAX = 1.0  # s: the longest a silent motor goes unread


@dataclass
class Backoff:
    """Per motor: failures in a row, since when it is silent, when it may be read again."""

    failures: dict[int, int] = field(default_factory=dict)
    silent_since: dict[int, float] = field(default_factory=dict)
    wait: dict[int, float] = field(default_factory=dict)
    next_try: dict[int, float] = field(default_factory=dict)

    def due(self, device_id: int, now: float) -> bool:
        """May this motor be read now? (always, unless it is silent and its wait is not over)"""
        return now >= self.next_try.get(device_id, 0.0)

    def silent(self, device_id: int) -> bool:
        return device_id in self.silent_since

    def failed(self, device_id: int, now: float) -> bool:
        """A read failed; True when the motor has just become silent (report it once)."""
        n = self.failures[device_id] = self.failures.get(device_id, 0) + 1
        if n < SILENT_AFTER:
            return False
        wait = self.wait[device_id] = min(BACKOFF_MAX, self.wait.get(device_id, 0.0) * 2 or BACKOFF_FIRST)
        self.next_try[device_id] = now + wait
        if device_id in self.silent_since:
            return False
        self.silent_since[device_id] = now
        return True

    def answered(self, device_id: int) -> float | None:
        """A read succeeded; returns since when it had been silent (None: it was not)."""
        self.failures.pop(device_id, None)
        self.wait.pop(device_id, None)
        self.next_try.pop(device_id, None)
        return self.silent_since.pop(device_id, None)


def read_state_once(motor: MotorProcedures) -> Generator[Any, Any, MotorState]:
    """A state reading with one attempt, no retries: for a motor that has stopped answering
    (its retries would cost the other motors their rate)."""
    name = "request_position" if motor.line.has("request_position") else "request_speed"
    answer = yield from motor.core.ask(motor._request(name, "a reading"), 0)
    return motor.state_from(answer)
