"""The primitive I/O actions that procedures yield and drivers carry out.

Procedures (generators) hold all the logic and know nothing of ports, threads or clocks;
a driver (sync: nurimc.client.sync, asyncio: nurimc.client.aio) performs each action and
sends its result back into the generator.
"""

from __future__ import annotations

from collections.abc import Generator
from dataclasses import dataclass
from typing import Any, TypeVar


@dataclass(frozen=True, slots=True)
class Send:
    """Write bytes to the bus. Result: None."""

    data: bytes


@dataclass(frozen=True, slots=True)
class Receive:
    """Read up to max_bytes, until `deadline` seconds after the last Send. Result: bytes (b"" = deadline passed)."""

    max_bytes: int
    deadline: float


@dataclass(frozen=True, slots=True)
class Discard:
    """Drop bytes already received. Result: the dropped bytes."""


@dataclass(frozen=True, slots=True)
class Wait:
    """Let time pass (e.g. a controller writing its EEPROM). Result: None."""

    seconds: float


@dataclass(frozen=True, slots=True)
class SetBaud:
    """Switch the host's baud rate. Result: None."""

    rate: int


@dataclass(frozen=True, slots=True)
class Note:
    """Report progress to whoever runs the procedure (e.g. discovery). Result: None."""

    event: Any


Action = Send | Receive | Discard | Wait | SetBaud | Note
T = TypeVar("T")
Procedure = Generator[Action, Any, T]
