"""A motor per controller ID, in physical units: degrees, RPM, amperes, seconds.

`MotorProcedures` holds the logic as procedures (sans-I/O). The motor API is written once,
in `MotorApi`: `Motor` runs each call on a sync Bus, `AsyncMotor` awaits it on an AsyncBus,
with the same methods, arguments and documentation. Builders (`make_*`) return the command
without sending it, for batches: `bus.send(*(m.make_run(30) for m in motors))`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any, Concatenate, Generic, ParamSpec, Protocol, TypeVar, overload

from .client.actions import Now, Procedure, Wait
from .client.core import BusCore
from .errors import InputError, NoAnswer, NotArrived, SettingNotApplied, ValueOutOfRange
from .multiturn import TurnTracker, signed_degrees
from .protocol import (
    PRODUCTS,
    AccelPosition,
    AccelSpeed,
    Command,
    Message,
    PositionFeedback,
    PositionSpeed,
    ProductSpec,
    RequestPosition,
    RequestSpeed,
    SetControl,
    SpeedFeedback,
    build_frame,
    make_command,
    make_request,
    message_class,
    units,
)
from .protocol.host import BUSY_POLL_INTERVAL, LIMITS
from .settings import SETTINGS, Setting, setting

POSITION_LIMIT = LIMITS["position_deg"]  # the largest position a command can carry, degrees
POSITION_WIRE_MAX = units.degrees_to_wire(POSITION_LIMIT)
SPEED_MIN, SPEED_MAX = LIMITS["speed_rpm_min"], LIMITS["speed_rpm_max"]
ARRIVAL_MIN, ARRIVAL_MAX = LIMITS["arrival_s_min"], LIMITS["arrival_s_max"]
EEPROM_SETTLE = 0.05  # kept for callers; the bus core now waits out each ID's busy window itself
VERIFY_WINDOW = 0.4  # how long a read-back may keep failing while the EEPROM write finishes
HOLD_RPM = 10.0
#: A motor reading below this speed is at rest (the wire's speed step is 0.1 RPM).
STOPPED_RPM = 1.0
#: How far from its target a motor at rest may read and still have arrived, degrees.
ARRIVAL_TOLERANCE = 1.0
#: How often wait_until_arrived() and stop() read the motor while waiting, seconds.
MOTION_POLL = 0.05
#: The default time wait_until_arrived() gives a move, seconds.
ARRIVAL_TIMEOUT = 30.0
#: stop(): after the ramp, how long speed 0 may take to show before the hold takes over, and
#: how long the hold may take to bring the motor to rest, seconds.
STOP_MARGIN = 0.3
STOP_SETTLE = 3.0


class SpeedZero(AccelSpeed):
    """§3 with speed 0: come to rest over the ramp time. The vendor's own programs stop a motor
    this way and its simulator decelerates on it, while the document's speed range starts at 1
    (docs/library.md, Stopping); built here because the generated message keeps to the document."""

    __slots__ = ()

    def encode(self) -> bytes:
        if not 0 <= self.id <= 0xFF or self.direction not in (0, 1) or not 1 <= self.arrival_time <= 255:
            raise ValueOutOfRange("stop", "ramp", self.arrival_time / 10, f"{ARRIVAL_MIN}..{ARRIVAL_MAX} s")
        return build_frame(self.id, self.SPEC.mode, self.SPEC.layout.pack(self.direction, 0, self.arrival_time))


@dataclass(frozen=True, slots=True)
class MotorState:
    """One reading. `position` is continuous across wraps; `device_position` is what the device said."""

    id: int
    position: float  # degrees, continuous (host-side multi-turn tracking)
    device_position: float  # degrees, signed, as reported (-655.35..655.35)
    speed: float  # RPM; magnitude from position feedback, signed from read_speed()
    current: float  # amperes
    direction: str  # "ccw" or "cw": the sign of device_position


def _direction(value: float) -> int:
    return 1 if value < 0 else 0


def _distance(a: float, b: float) -> float:
    """Degrees between two device positions (the register wraps at ±655.36)."""
    turn = 2 * 655.36
    d = (a - b) % turn
    return min(d, turn - d)


class MotorProcedures:
    """Everything a motor handle does, as procedures on a BusCore."""

    def __init__(self, core: BusCore, device_id: int, product: str = "mc") -> None:
        if product not in PRODUCTS:
            raise InputError(f"unknown product {product!r}; products: {', '.join(PRODUCTS)}")
        self.core = core
        core.products[device_id] = product  # its busy window comes from this product's profile
        self.id = device_id
        self.profile: ProductSpec = PRODUCTS[product]
        self.tracker = TurnTracker()
        self._relative: bool | None = None  # position mode, read before the first move
        self._target: float | None = None  # the last move's target, device degrees (None: a speed)

    # -- builders (no I/O) --------------------------------------------------
    def make_move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> Command:
        """Position command for a signed target (CCW +). Give rpm (§1) or arrival seconds (§2)."""
        if (rpm is None) == (seconds is None):
            raise InputError("give exactly one of rpm= (speed) or seconds= (arrival time)")
        # rounded to the nearest step first, then range-checked (655.334 is 65533, allowed)
        position = units.degrees_to_wire(abs(degrees)) if math.isfinite(degrees) else POSITION_WIRE_MAX + 1
        if position > POSITION_WIRE_MAX:
            raise ValueOutOfRange("move", "degrees", degrees, f"-{POSITION_LIMIT}..{POSITION_LIMIT}°")
        if rpm is not None:
            return PositionSpeed(self.id, _direction(degrees), position, self._speed_wire("move", rpm))
        assert seconds is not None
        return AccelPosition(self.id, _direction(degrees), position, self._seconds_wire(seconds))

    def make_run(self, rpm: float, ramp_seconds: float = 0.1) -> Command:
        """Speed command: signed RPM (CCW +), reached in ramp_seconds (§3)."""
        if rpm == 0:
            raise ValueOutOfRange(
                "run", "rpm", rpm, "a non-zero speed (speed 0 is invalid for run(): stop() stops, release() lets go)"
            )
        return AccelSpeed(self.id, _direction(rpm), self._speed_wire("run", abs(rpm)), self._seconds_wire(ramp_seconds))

    def make_release(self) -> Command:
        return SetControl(self.id, 1)

    def make_stop(self, ramp_seconds: float = 0.5) -> Command:
        """Speed 0 reached in ramp_seconds (§3 with speed 0: see stop())."""
        return SpeedZero(self.id, 0, 0, self._seconds_wire(ramp_seconds))

    def _speed_wire(self, what: str, rpm: float) -> int:
        raw = units.rpm_to_wire(abs(rpm)) if math.isfinite(rpm) else 0
        if not 1 <= raw <= 65533:
            raise ValueOutOfRange(what, "rpm", rpm, f"{SPEED_MIN}..{SPEED_MAX} RPM")
        return raw

    @staticmethod
    def _seconds_wire(seconds: float) -> int:
        raw = units.seconds_to_wire(seconds) if math.isfinite(seconds) else 0
        if not 1 <= raw <= 255:
            raise ValueOutOfRange("motion", "seconds", seconds, f"{ARRIVAL_MIN}..{ARRIVAL_MAX} s")
        return raw

    # -- motion ---------------------------------------------------------------
    def _position_mode_is_relative(self) -> Procedure[bool]:
        if self._relative is None:
            answer = yield from self.core.ask(make_request("request_position_mode", self.id))
            self._relative = answer.fields()["position_mode"] == 1
        return self._relative

    def _enable_if_released(self) -> Procedure[None]:
        """Control on if it is off (read once if unknown). The motion that follows waits out the
        busy window this starts (docs/protocol.md, Busy window, rule 5)."""
        released = self.core.control_released.get(self.id)
        if released is None:
            answer = yield from self.core.ask(make_request("request_control", self.id))
            released = answer.fields()["control"] == 1
            self.core.control_released.setdefault(self.id, released)
        if released:
            yield from self.core.tell(SetControl(self.id, 0))

    def move_to(
        self,
        degrees: float,
        rpm: float | None = None,
        seconds: float | None = None,
        *,
        wait: bool = False,
        timeout: float = ARRIVAL_TIMEOUT,
    ) -> Procedure[None]:
        """Go to an absolute signed position (in the device's frame, ±655.33 deg). With
        wait=True, return once the motor is at rest there (see wait_until_arrived())."""
        command = self.make_move_to(degrees, rpm, seconds)
        if (yield from self._position_mode_is_relative()):
            state = yield from self.read_state()
            command = self.make_move_to(degrees - state.device_position, rpm, seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)
        self._target = degrees
        if wait:
            yield from self.wait_until_arrived(timeout)

    def move_by(
        self,
        degrees: float,
        rpm: float | None = None,
        seconds: float | None = None,
        *,
        wait: bool = False,
        timeout: float = ARRIVAL_TIMEOUT,
    ) -> Procedure[None]:
        """Move by a signed amount from where the motor is. With wait=True, return once the
        motor is at rest there (see wait_until_arrived())."""
        state = yield from self.read_state()
        target = state.device_position + degrees
        if (yield from self._position_mode_is_relative()):
            command = self.make_move_to(degrees, rpm, seconds)
        else:
            command = self.make_move_to(target, rpm, seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)
        self._target = target
        if wait:
            yield from self.wait_until_arrived(timeout)

    def wait_until_arrived(
        self, timeout: float = ARRIVAL_TIMEOUT, tolerance: float = ARRIVAL_TOLERANCE
    ) -> Procedure[MotorState]:
        """Read the motor until it is at rest (two readings in a row under 1 RPM) within
        `tolerance` degrees of the last move's target; the last reading. NotArrived after
        `timeout` seconds, saying where the motor is. After run(), waits for rest anywhere."""
        start: float = yield Now()
        at_rest = 0
        while True:
            state = yield from self.read_state()
            there = self._target is None or _distance(state.device_position, self._target) <= tolerance
            at_rest = at_rest + 1 if there and state.speed < STOPPED_RPM else 0
            if at_rest >= 2:
                return state
            now: float = yield Now()
            if now - start >= timeout:
                goal = "at rest" if self._target is None else f"at {self._target:g}°"
                raise NotArrived(
                    f"ID {self.id}: not {goal} after {timeout:g} s (it reads {state.device_position:g}° at "
                    f"{state.speed:g} RPM); give a longer timeout, or check the load, the gains and the rated current"
                )
            yield Wait(MOTION_POLL)

    def run(self, rpm: float, ramp_seconds: float = 0.1) -> Procedure[None]:
        command = self.make_run(rpm, ramp_seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)
        self._target = None

    def stop(self, ramp_seconds: float = 0.5) -> Procedure[MotorState]:
        """Come to rest and hold there, whichever way the firmware reads speed 0.

        Sends speed 0 over `ramp_seconds` (how the vendor's programs stop; its simulator
        decelerates), reads the speed back until it is under 1 RPM or the ramp has passed
        (a firmware keeping to the document's range 1.. ignores speed 0), then holds the
        present position, which brings either kind to rest. Returns the reading at rest;
        NotArrived if the motor still turns 3 s after the hold. release() lets go instead."""
        command = self.make_stop(ramp_seconds)
        yield from self.core.tell(command)
        self._target = None
        start: float = yield Now()
        while True:
            speed = yield from self.read_speed()
            if abs(speed) < STOPPED_RPM:
                break
            now: float = yield Now()
            if now - start >= ramp_seconds + STOP_MARGIN:
                break  # speed 0 was ignored: the hold below stops it
            yield Wait(MOTION_POLL)
        yield from self.hold()
        if (yield from self._position_mode_is_relative()):  # hold() only turned control on: a
            yield from self.core.tell(self.make_move_to(0.0, rpm=HOLD_RPM))  # step of 0 holds here
        return (yield from self.wait_until_arrived(STOP_SETTLE, tolerance=math.inf))

    def release(self) -> Procedure[None]:
        """Control off: the motor is no longer driven and coasts to a stop."""
        yield from self.core.tell(self.make_release())

    def hold(self) -> Procedure[None]:
        """Control on, holding the present position."""
        yield from self.core.tell(SetControl(self.id, 0))
        self._target = None
        if (yield from self._position_mode_is_relative()):
            return
        state = yield from self.read_state()
        yield from self.core.tell(self.make_move_to(state.device_position, rpm=HOLD_RPM))

    # -- feedback -------------------------------------------------------------
    def state_from(self, answer: Message) -> MotorState:
        """A MotorState from a position feedback answer (also used by group reads)."""
        assert isinstance(answer, PositionFeedback)
        device = signed_degrees(answer.direction, units.from_wire(answer.position, 0.01))
        return MotorState(
            id=self.id,
            position=self.tracker.update(device),
            device_position=device,
            speed=units.from_wire(answer.speed, 0.1),
            current=units.from_wire(answer.current, 0.1),
            direction="cw" if answer.direction == 1 else "ccw",
        )

    def read_state(self) -> Procedure[MotorState]:
        answer = yield from self.core.ask(RequestPosition(self.id))
        return self.state_from(answer)

    def read_speed(self) -> Procedure[float]:
        """Signed speed in RPM (CCW +) from speed feedback (§20)."""
        answer = yield from self.core.ask(RequestSpeed(self.id))
        assert isinstance(answer, SpeedFeedback)
        return signed_degrees(answer.direction, units.from_wire(answer.speed, 0.1))

    def ping(self) -> Procedure[bool]:
        yield from self.core.ask(make_request("request_ping", self.id))
        return True

    # -- settings -------------------------------------------------------------
    def get(self, name: str) -> Procedure[float | int | str]:
        s = setting(name)
        answer = yield from self.core.ask(make_request(s.request, self.id))
        raw = answer.fields()[s.field]
        self._remember(s, raw)
        return s.to_physical(raw)

    def read_settings(self) -> Procedure[dict[str, float | int | str]]:
        """Every setting, reading each feedback request once."""
        answers: dict[str, Message] = {}
        out: dict[str, float | int | str] = {}
        for s in SETTINGS.values():
            if s.answer not in answers:
                answers[s.answer] = yield from self.core.ask(make_request(s.request, self.id))
            raw = answers[s.answer].fields()[s.field]
            self._remember(s, raw)
            out[s.name] = s.to_physical(raw)
        return out

    def set(self, name: str, value: object) -> Procedure[float | int | str]:
        """Write a setting in physical units and verify it by reading it back."""
        s = setting(name)
        if s.command is None:
            raise InputError(f"{s.name} is read-only")
        raw = s.to_wire(value)
        if s.field == "rated_current" and raw > self.profile.max_rated_current:
            raise ValueOutOfRange(
                s.name, "value", value, f"0.1..{self.profile.max_rated_current / 10} A for {self.profile.title}"
            )
        fields = {s.field: raw}
        if len(message_class(s.command).SPEC.fields) > 1:  # gains: written together
            current = yield from self.core.ask(make_request(s.request, self.id))
            fields = {**current.fields(), s.field: raw}
        yield from self.write_verified(s, make_command(s.command, self.id, **fields), raw)
        return s.to_physical(raw)

    def write_verified(self, s: Setting, command: Command, raw: int) -> Procedure[None]:
        """Send a settings command, then read it back until it matches.

        The core holds the read-back until the busy window has ended; a controller slower than
        its window is polled for one more window before the write is called failed."""
        yield from self.core.tell(command)
        self._remember(s, raw)
        got: int | None = None
        give_up: float | None = None
        while True:
            try:
                answer = yield from self.core.ask(make_request(s.request, self.id), retries=0)
                got = answer.fields()[s.field]
                if got == raw:
                    return
            except NoAnswer:
                pass
            now: float = yield Now()
            if give_up is None:
                give_up = now + self.core.window(self.id)
            if now >= give_up:
                break
            yield Wait(BUSY_POLL_INTERVAL)
        self._relative = None
        said = "no answer" if got is None else f"it reads {s.to_physical(got)}"
        raise SettingNotApplied(
            f"ID {self.id}: wrote {s.name} = {s.to_physical(raw)} but {said}; the change did not take "
            "(check the value is allowed for this product, then try again)"
        )

    def _remember(self, s: Setting, raw: int) -> None:
        if s.name == "response-time":
            self.core.response_times[self.id] = raw * 100e-6
        elif s.name == "position-mode":
            self._relative = raw == 1
        elif s.name == "control":
            self.core.control_released[self.id] = raw == 1


P = ParamSpec("P")
T = TypeVar("T")


class SyncRunner(Protocol):
    """What a sync handle needs of its bus (nurimc.client.sync.Bus). A protocol, not an
    import: the buses hand out motors, so motor must not import them (no import cycle)."""

    @property
    def core(self) -> BusCore: ...
    def run(self, procedure: Procedure[T]) -> T: ...


class AsyncRunner(Protocol):
    """What an async handle needs of its bus (nurimc.client.aio.AsyncBus)."""

    @property
    def core(self) -> BusCore: ...
    async def run(self, procedure: Procedure[T]) -> T: ...


class SyncHandle:
    """A handle whose calls run now and return their result."""

    bus: SyncRunner


class AsyncHandle:
    """A handle whose calls return awaitables."""

    bus: AsyncRunner


class _Call(Generic[P, T]):
    """One motor call, written once: runs its procedure on the handle's bus, sync or async."""

    def __init__(self, procedure: Callable[Concatenate[MotorProcedures, P], Procedure[T]]) -> None:
        self.procedure = procedure
        self.__doc__ = procedure.__doc__

    @overload
    def __get__(self, handle: None, owner: type) -> _Call[P, T]: ...
    @overload
    def __get__(self, handle: SyncHandle, owner: type) -> Callable[P, T]: ...
    @overload
    def __get__(self, handle: AsyncHandle, owner: type) -> Callable[P, Awaitable[T]]: ...
    def __get__(self, handle: object, owner: type) -> Any:
        if handle is None:
            return self
        procedure = self.procedure
        procedures: MotorProcedures = handle.procedures  # type: ignore[attr-defined]
        run = handle.bus.run  # type: ignore[attr-defined]

        @functools.wraps(procedure)
        def call(*args: P.args, **kwargs: P.kwargs) -> Any:
            return run(procedure(procedures, *args, **kwargs))

        return call


class MotorApi:
    """The motor API, once for both buses. Every call sends now (or raises); make_* build only."""

    def __init__(self, bus: SyncRunner | AsyncRunner, device_id: int, product: str = "mc") -> None:
        self.procedures = MotorProcedures(bus.core, device_id, product)
        self.id = device_id
        self.make_move_to = self.procedures.make_move_to
        self.make_run = self.procedures.make_run
        self.make_release = self.procedures.make_release
        self.make_stop = self.procedures.make_stop

    def __repr__(self) -> str:
        return f"{type(self).__name__}(id={self.id}, product={self.procedures.profile.key!r})"

    move_to = _Call(MotorProcedures.move_to)
    move_by = _Call(MotorProcedures.move_by)
    run = _Call(MotorProcedures.run)
    wait_until_arrived = _Call(MotorProcedures.wait_until_arrived)
    stop = _Call(MotorProcedures.stop)
    release = _Call(MotorProcedures.release)
    hold = _Call(MotorProcedures.hold)
    read_state = _Call(MotorProcedures.read_state)
    read_speed = _Call(MotorProcedures.read_speed)
    ping = _Call(MotorProcedures.ping)
    get = _Call(MotorProcedures.get)
    set = _Call(MotorProcedures.set)
    read_settings = _Call(MotorProcedures.read_settings)


class Motor(MotorApi, SyncHandle):
    """A motor on a sync Bus: `bus.motor(1).move_to(90, rpm=30)`."""

    def __init__(self, bus: SyncRunner, device_id: int, product: str = "mc") -> None:
        super().__init__(bus, device_id, product)
        self.bus = bus


class AsyncMotor(MotorApi, AsyncHandle):
    """A motor on an AsyncBus: `await bus.motor(1).move_to(90, rpm=30)`."""

    def __init__(self, bus: AsyncRunner, device_id: int, product: str = "mc") -> None:
        super().__init__(bus, device_id, product)
        self.bus = bus
