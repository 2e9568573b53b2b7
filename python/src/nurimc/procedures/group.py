"""Many motors at once: commands back to back, reads in the least bus time.

- `command`: one write carrying every command (no answers to wait for).
- `read_states`: one request per motor, each answered before the next (half-duplex), with
  deadlines from the wire so a missing motor costs milliseconds, not a fixed timeout.
- `stagger` + `read_states_broadcast`: space the motors' response times so that a single
  broadcast request is answered by all of them in turn. Outside the document's §17 (requests
  to ID 0xFF); use it where the controllers answer broadcast requests.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

from ..core.actions import Now, Procedure
from ..core.buscore import BusCore
from ..core.handles import AsyncHandle, AsyncRunner, HandleCall, SyncHandle, SyncRunner
from ..errors import InputError, NoAnswer, UnexpectedAnswer, UsageError
from ..protocol import Command, RequestPosition, SetResponseTime
from .motor import AsyncMotor, Motor, MotorProcedures, MotorState
from .settings import SETTINGS

FEEDBACK_LENGTH = 12  # bytes of a position feedback frame


def read_states(motors: Sequence[MotorProcedures]) -> Procedure[dict[int, MotorState | Exception]]:
    """Each motor's state; a motor that does not answer gets its error instead of stopping the rest."""
    out: dict[int, MotorState | Exception] = {}
    for motor in motors:
        try:
            out[motor.id] = yield from motor.read_state()
        except (NoAnswer, UnexpectedAnswer) as err:
            out[motor.id] = err
    return out


def stagger_slot(baudrate: int) -> int:
    """Response-time units (100 us) between two motors' answers: one feedback frame plus half again."""
    return max(1, math.ceil(1.5 * FEEDBACK_LENGTH * 10 / baudrate / 100e-6))


def stagger(motors: Sequence[MotorProcedures], baudrate: int) -> Procedure[int]:
    """Give motor k the response time (k + 1) * slot, verified; returns the slot in 100 us units."""
    slot = stagger_slot(baudrate)
    if slot * len(motors) > 254:
        raise InputError(
            f"{len(motors)} motors need {slot * len(motors)} response-time units at {baudrate} bps but "
            f"254 is the most; stagger at most {254 // slot} motors at this rate, or use a faster rate"
        )
    for k, motor in enumerate(motors):
        raw = (k + 1) * slot
        yield from motor.write_verified(SETTINGS["response-time"], SetResponseTime(motor.id, raw), raw)
    return slot


def broadcast_window(core: BusCore, count: int, slot: int) -> float:
    """How long the answers of `count` staggered motors may take, from the end of the request."""
    window = (count + 1) * slot * 100e-6 + core.timing.wire_time(6 + FEEDBACK_LENGTH, core.baudrate)
    return window + 2 * core.timing.latency + core.timing.margin


def read_states_broadcast(motors: Sequence[MotorProcedures], slot: int) -> Procedure[dict[int, MotorState | Exception]]:
    """One broadcast position request, every staggered motor answering in turn; a motor
    whose answer did not come is asked again on its own, and one that still does not answer
    gets its error in its slot (as read_states). Always one entry per motor, in order."""
    if not motors:
        return {}
    core = motors[0].core
    ids = [m.id for m in motors]
    window = broadcast_window(core, len(motors), slot)
    answers, _ = yield from core.broadcast_ask(RequestPosition, window, ids=ids, ordered=True)
    got = {a.id: a for a in answers}
    # one time for the whole broadcast: each motor keeps its place in it, so the time between
    # its readings (what the multi-turn tracking needs) is right
    at: float = yield Now()
    out: dict[int, MotorState | Exception] = {}
    for motor in motors:
        if motor.id in got:
            out[motor.id] = motor.state_from(got[motor.id], at)
            continue
        try:  # asked on its own, behind a fence: its late answer to the broadcast cannot be taken
            answer = yield from core.ask(RequestPosition(motor.id))
            alone: float = yield Now()
            out[motor.id] = motor.state_from(answer, alone)
        except (NoAnswer, UnexpectedAnswer) as err:
            out[motor.id] = err
    return out


class GroupProcedures:
    """Everything a group handle does, as procedures on its motors' BusCore."""

    def __init__(self, core: BusCore, motors: Sequence[MotorProcedures]) -> None:
        self.core = core
        self.motors = list(motors)
        self.slot: int | None = None  # response-time units between staggered motors, once staggered

    def command(self, commands: Sequence[Command]) -> Procedure[None]:
        """Send every command in one write (commands are never answered)."""
        yield from self.core.tell(*commands)

    def read_states(self) -> Procedure[dict[int, MotorState | Exception]]:
        """Each motor's state, one request per motor; a missing motor gets its error."""
        return (yield from read_states(self.motors))

    def stagger(self) -> Procedure[int]:
        """Space the motors' response times for read_states_broadcast; returns the slot."""
        self.slot = yield from stagger(self.motors, self.core.baudrate)
        return self.slot

    def read_states_broadcast(self) -> Procedure[dict[int, MotorState | Exception]]:
        """Every state from one broadcast request (after stagger()); one entry per motor, in order."""
        if self.slot is None:
            raise UsageError("call stagger() first: the motors' response times must be spaced")
        return (yield from read_states_broadcast(self.motors, self.slot))


class SyncBusLike(SyncRunner, Protocol):
    """What a Group needs of its bus: run procedures and hand out motors (nurimc.Bus)."""

    def motor(self, device_id: int, product: str = "mc") -> Motor: ...


class AsyncBusLike(AsyncRunner, Protocol):
    """What an AsyncGroup needs of its bus (nurimc.AsyncBus)."""

    def motor(self, device_id: int, product: str = "mc") -> AsyncMotor: ...


def read_states_now(bus: Any, motors: Sequence[MotorProcedures]) -> dict[int, MotorState | Exception]:
    """`read_states(motors)` on a sync bus: through its single-request calls when it has them
    (drivers/fastpath.py; one request per motor under one hold of the bus lock, the same errors
    kept per motor, each reading converted with the time it was read, as read_state), else run as
    the procedure. Group.read_states and the ROS 2 bridge's round read this way."""
    if getattr(bus, "_request_each", None) is None:
        return dict(bus.run(read_states(motors)))
    states = bus._request_each([(m.state_request(), m.state_from) for m in motors], (NoAnswer, UnexpectedAnswer))
    return dict(zip([m.id for m in motors], states, strict=True))


def _read_states_in_place(bus: Any, group: GroupProcedures) -> dict[int, MotorState | Exception]:
    """GroupProcedures.read_states through the bus's single-request calls (read_states_now)."""
    return read_states_now(bus, group.motors)


class GroupApi:
    """The group API, once for both buses (as MotorApi: each call runs its procedure)."""

    procedures: GroupProcedures

    @property
    def slot(self) -> int | None:
        """Response-time units between staggered motors (None until stagger())."""
        return self.procedures.slot

    @slot.setter
    def slot(self, value: int | None) -> None:
        self.procedures.slot = value

    command = HandleCall(GroupProcedures.command)
    read_states = HandleCall(GroupProcedures.read_states, lambda bus, g: _read_states_in_place(bus, g))
    stagger = HandleCall(GroupProcedures.stagger)
    read_states_broadcast = HandleCall(GroupProcedures.read_states_broadcast)


class Group(GroupApi, SyncHandle):
    """Motors of one sync Bus used together."""

    def __init__(self, bus: SyncBusLike, ids: Sequence[int], product: str = "mc") -> None:
        self.bus = bus
        self.motors = [bus.motor(i, product) for i in ids]
        self.procedures = GroupProcedures(bus.core, [m.procedures for m in self.motors])


class AsyncGroup(GroupApi, AsyncHandle):
    """Motors of one AsyncBus used together: Group's methods, awaited."""

    def __init__(self, bus: AsyncBusLike, ids: Sequence[int], product: str = "mc") -> None:
        self.bus = bus
        self.motors = [bus.motor(i, product) for i in ids]
        self.procedures = GroupProcedures(bus.core, [m.procedures for m in self.motors])
