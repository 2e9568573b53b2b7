"""The one emergency stop, as a procedure (sans-I/O: any driver runs it; docs/service.md).

Control off is broadcast at every rate a motor was seen at (and the present one), then each
known motor is read back, and told again, until it reads "off" or the window of spec/host.json
("stop": verify_s) runs out. The result names every motor it could not read back: a stop that
read nothing back is never "ok".
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..core.actions import Note, Now, Procedure, WaitUntil
from ..core.buscore import BusCore
from ..errors import NurimcError, PortLost
from ..protocol import BROADCAST_ID, SetControl
from ..protocol.host import STOP_RECHECK, STOP_VERIFY
from .motor import MotorProcedures
from .settings import setting

#: s between two read-backs of a motor that did not answer (its timeouts would hold the bus up)
SILENT_RECHECK = 0.25


@dataclass(frozen=True, slots=True)
class Idle:
    """Noted by the stop between two read-backs: the bus is free until `until` (clock time); a
    driver may read other motors meanwhile (the bus service keeps polling during the stop)."""

    until: float


@dataclass(frozen=True, slots=True)
class StopResult:
    """What an emergency stop did: `stopped` read back control off, `not_confirmed` did not
    (no answer, or still on when the window ran out). `ok` only when every known motor read back
    off and at least one motor was known."""

    stopped: tuple[int, ...]
    not_confirmed: tuple[int, ...]
    rates: tuple[int, ...]
    control: dict[str, str] = field(default_factory=dict)
    latched: tuple[int, ...] = ()

    @property
    def ok(self) -> bool:
        return bool(self.stopped) and not self.not_confirmed

    def as_dict(self) -> dict[str, Any]:
        return {
            "ok": self.ok,
            "stopped": list(self.stopped),
            "not_confirmed": list(self.not_confirmed),
            "rates": list(self.rates),
            "control": dict(self.control),
            "latched": list(self.latched),
        }

    def text(self) -> str:
        """One line for people."""
        if not self.stopped and not self.not_confirmed:
            return (
                "emergency stop: control off broadcast at "
                + ", ".join(f"{r} bps" for r in self.rates)
                + ", but no motor is known to read back: not confirmed (give --id, or discover first)"
            )
        parts = []
        if self.stopped:
            parts.append("ID " + ", ".join(map(str, self.stopped)) + " read back off")
        if self.not_confirmed:
            parts.append(
                "ID "
                + ", ".join(map(str, self.not_confirmed))
                + " NOT confirmed (no answer or still on): stop them by other means (cut their power)"
            )
        return "emergency stop: " + "; ".join(parts)


def _at_rate(core: BusCore, rate: int) -> Procedure[None]:
    if core.baudrate != rate:
        yield from core.set_baud(rate)


def emergency_stop(
    core: BusCore,
    motors: Mapping[int, tuple[MotorProcedures, int]],
    verify_seconds: float = STOP_VERIFY,
    extra_rates: tuple[int, ...] = (),
) -> Procedure[StopResult]:
    """Control off, broadcast at every rate a motor was found at (the present one and
    `extra_rates` too), then each motor told and read back until it reads "off" or
    `verify_seconds` pass.

    `motors`: ID -> (its procedures, the rate it answers at). A controller busy writing its
    EEPROM (50-300 ms) ignores frames, so a broadcast can be lost on it: each one is told again
    until it confirms. A lost port (PortLost) is never swallowed: the caller latches the stop.
    """
    rates = tuple(sorted({*(rate for _, rate in motors.values()), core.baudrate, *extra_rates}))
    for rate in rates:
        yield from _at_rate(core, rate)
        yield from core.tell(SetControl(BROADCAST_ID, 1))
    for motor, rate in motors.values():
        yield from _at_rate(core, rate)
        yield from _told_again(motor)
    controls: dict[str, str] = {}
    unconfirmed = set(motors)
    deadline = (yield Now()) + verify_seconds
    first = True
    next_look: dict[int, float] = {}
    while unconfirmed:
        for device_id in sorted(unconfirmed):
            if next_look.get(device_id, 0.0) > (yield Now()):
                continue
            motor, rate = motors[device_id]
            yield from _at_rate(core, rate)
            # the first read-back is retried as any read; later rounds are the retries
            controls[str(device_id)] = value = yield from _control(motor, None if first else 0)
            if value == "off":
                unconfirmed.discard(device_id)
            elif value == "on":  # still on (a lost broadcast, a busy controller): tell it again
                yield from _told_again(motor)
            else:  # no answer: looked at less often, so its timeouts do not hold up the bus
                next_look[device_id] = (yield Now()) + SILENT_RECHECK
            yield Note(Idle((yield Now())))  # the driver may read other motors here
        first = False
        now = yield Now()
        if not unconfirmed or now >= deadline:
            break
        yield Note(Idle(now + STOP_RECHECK))
        yield WaitUntil(now + STOP_RECHECK)
    stopped = tuple(sorted(set(motors) - unconfirmed))
    return StopResult(stopped, tuple(sorted(unconfirmed)), rates, controls)


def _told_again(motor: MotorProcedures) -> Procedure[None]:
    try:
        yield from motor.release()  # the handle remembers: the next move turns control on again
    except PortLost:
        raise
    except NurimcError:  # the broadcast went out; the read-back tells the truth
        pass


def _control(motor: MotorProcedures, retries: int | None) -> Procedure[str]:
    s = setting("control")
    try:
        answer = yield from motor.core.ask(motor._request(s.request, s.name), retries)
        return str(s.to_physical(answer.fields()[s.field]))
    except PortLost:
        raise
    except NurimcError as error:
        return f"unknown: {error}"
