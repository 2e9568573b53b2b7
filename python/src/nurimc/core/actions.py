"""The primitive I/O actions that procedures yield and drivers carry out.

Procedures (generators) hold all the logic and know nothing of ports, threads or clocks;
a driver (sync: nurimc.drivers.sync, asyncio: nurimc.drivers.aio) performs each action and
sends its result back into the generator. Times are the driver's clock (seconds, monotonic);
a procedure only compares and adds them. The contract between the two: docs/drivers.md.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass
from typing import Any, NamedTuple, TypeVar


class Sent(NamedTuple):
    """When a write ran: `started` just before the write call, `finished` just after it returned."""

    started: float
    finished: float


@dataclass(frozen=True, slots=True)
class Send:
    """Write bytes to the bus. Result: Sent(started, finished)."""

    data: bytes


@dataclass(frozen=True, slots=True)
class Receive:
    """Read up to max_bytes, until the clock reads `until`. Result: bytes (b"" = time is up).

    A driver that wakes after `until` (a loaded host) still hands over what has already
    arrived, so a slow host costs nothing but time."""

    max_bytes: int
    until: float


@dataclass(frozen=True, slots=True)
class Discard:
    """Drop bytes already received. Result: the dropped bytes."""


@dataclass(frozen=True, slots=True)
class Wait:
    """Let time pass (e.g. a controller writing its EEPROM). Result: None."""

    seconds: float


@dataclass(frozen=True, slots=True)
class WaitUntil:
    """Let time pass until the clock reads `when` (no wait if it has). Result: the clock after."""

    when: float


@dataclass(frozen=True, slots=True)
class Now:
    """Read the driver's clock. Result: float seconds."""


@dataclass(frozen=True, slots=True)
class SetHostBaud:
    """Switch the host's baud rate. Result: None."""

    rate: int


@dataclass(frozen=True, slots=True)
class Note:
    """Report progress to whoever runs the procedure (e.g. discovery). Result: None."""

    event: Any


Action = Send | Receive | Discard | Wait | WaitUntil | Now | SetHostBaud | Note
T = TypeVar("T")
Procedure = Generator[Action, Any, T]
