"""A motor per controller ID, in physical units: degrees, RPM, amperes, seconds.

`MotorProcedures` holds the logic as procedures (sans-I/O). The motor API is written once,
in `MotorApi`: `Motor` runs each call on a sync Bus, `AsyncMotor` awaits it on an AsyncBus,
with the same methods, arguments and documentation. Builders (`make_*`) return the command
without sending it, for batches: `bus.send(*(m.make_run(30) for m in motors))`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..core.actions import Now, Procedure, Wait
from ..core.buscore import BusCore
from ..core.handles import AsyncHandle, AsyncRunner, HandleCall, SyncHandle, SyncRunner
from ..errors import InputError, NoAnswer, NotArrived, SettingNotApplied, ValueOutOfRange
from ..protocol import (
    BROADCAST_ID,
    PRODUCTS,
    AccelSpeed,
    Command,
    Message,
    ProductSpec,
    Request,
    build_frame,
    product_line,
    units,
)
from ..protocol.host import BUSY_POLL_INTERVAL, LIMITS
from .multiturn import WRAP_DEGREES, TurnTracker, signed_degrees
from .settings import SETTINGS, Setting, confirmed_answer, fields_differ, setting

if TYPE_CHECKING:
    from .tuning import TuneResult

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


@functools.cache
def _speed_zero_class(ramped: type[Command]) -> type[Command]:
    """SpeedZero for another line's ramped-speed message (its own mode byte, the same layout)."""
    return type(f"{ramped.__name__}SpeedZero", (ramped,), {"__slots__": (), "encode": SpeedZero.encode})


@dataclass(frozen=True, slots=True)
class MotorState:
    """One reading. `position` is continuous across wraps; `device_position` is what the device said."""

    id: int
    position: float  # degrees, continuous (host-side multi-turn tracking)
    device_position: float  # degrees, signed, as reported (-655.35..655.35)
    speed: float  # RPM, signed (CCW +): speed feedback's direction byte, else the position trend
    current: float  # amperes
    direction: str  # "ccw" or "cw": the sign of device_position
    #: False while position feedback's unsigned speed has no trend yet (the first reading of a
    #: turning motor): `speed` is then the magnitude; read_speed() gives the sign in one request
    speed_signed: bool = True
    #: the continuous position may be off by whole 655.36 deg turns (a gap too long for the
    #: speed to decide; docs/library.md, Multi-turn position); stays set until tracker.reset()
    position_uncertain: bool = False


@functools.cache
def _feedback(cls: type[Message]) -> tuple[bool, int, int, int, int, int]:
    """How state_from reads an answer class: whether its speed is signed (speed feedback), the
    indexes of direction, position, speed and current in the message, and the position's steps
    per degree (position feedback 0.01 deg; speed feedback 0.1 deg, erratum 6)."""
    name = cls.SPEC.name
    assert name in ("position_feedback", "speed_feedback"), name
    index = {field: i + 1 for i, field in enumerate(cls.SPEC.field_names)}
    return (
        name == "speed_feedback",
        index["direction"],
        index["position"],
        index["speed"],
        index["current"],
        10 if name == "speed_feedback" else 100,
    )


def _direction(value: float) -> int:
    return 1 if value < 0 else 0


def _unsupported(line: str, title: str, device_id: int, what: str, name: str) -> str:
    """Why a product line cannot do something (docs/protocol.md, Product lines)."""
    if line == "sm" and name in ("accel_speed", "set_speed_gains", "set_id", "set_baud", "set_response_time"):
        return (
            f"ID {device_id} is an SM whose table is not known: {what} needs {name}, whose code the vendor's "
            "two SM tables disagree on (C# 01-05, README 03/05; under the C# table the README's 03 is 'set ID'); "
            "give --product sm-cs or sm-readme (bus.motor(id, 'sm-cs')) once you know which it speaks"
        )
    if name in ("position_speed", "accel_position", "request_position", "request_position_mode"):
        return (
            f"ID {device_id} is an {title}, a speed-only motor: it has no position commands ({what}); "
            "use run() or release()"
        )
    return f"ID {device_id} is an {title}: the {title} line has no {name} ({what}); nothing was sent"


def _distance(a: float, b: float) -> float:
    """Degrees between two device positions (the register wraps at ±655.36)."""
    turn = 2 * WRAP_DEGREES
    d = (a - b) % turn
    return min(d, turn - d)


#: run()'s ramp when none is given (s): the library's, the CLI's (`nurimc run`) and the TypeScript library's.
RUN_RAMP = 0.1


class MotorProcedures:
    """Everything a motor handle does, as procedures on a BusCore."""

    def __init__(self, core: BusCore, device_id: int, product: str = "mc") -> None:
        if product not in PRODUCTS:
            raise InputError(f"unknown product {product!r}; products: {', '.join(PRODUCTS)}")
        self.core = core
        core.products[device_id] = product  # its busy window comes from this product's profile
        self.id = device_id
        self.profile: ProductSpec = PRODUCTS[product]
        #: the product line's message table (spec/lines.json): every frame is built in it
        self.line = product_line(product)
        self._requests: dict[str, Request] = {}
        self._state_request: Request | None = None  # what read_state sends, once known
        self.tracker = TurnTracker()
        self._relative: bool | None = None  # position mode, read before the first move
        self._target: float | None = None  # the last move's target, device degrees (None: a speed)

    # -- builders (no I/O) --------------------------------------------------
    def _message(self, name: str, what: str, **fields: int) -> Message:
        """The line's message `name` for this ID, or InputError saying the line has none
        (never another line's frame: the same mode byte means something else there)."""
        if not self.line.has(name):
            raise InputError(_unsupported(self.line.key, self.line.title, self.id, what, name))
        return self.line.make(name, self.id, **fields)

    def _command(self, name: str, what: str, **fields: int) -> Command:
        message = self._message(name, what, **fields)
        assert isinstance(message, Command)
        return message

    def _request(self, name: str, what: str) -> Request:
        kept = self._requests.get(name)  # a request has no fields but the ID: made once per name
        if kept is not None:
            return kept
        message = self._message(name, what)
        assert isinstance(message, Request)
        if not message.SPEC.fields:
            self._requests[name] = message
        return message

    def make_move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> Command:
        """Position command for a signed target (CCW +). Give rpm (§1) or arrival seconds (§2)."""
        if (rpm is None) == (seconds is None):
            raise InputError("give exactly one of rpm= (speed) or seconds= (arrival time)")
        # rounded to the nearest step first, then range-checked (655.334 is 65533, allowed)
        position = units.degrees_to_wire(abs(degrees)) if math.isfinite(degrees) else POSITION_WIRE_MAX + 1
        if position > POSITION_WIRE_MAX:
            raise ValueOutOfRange("move", "degrees", degrees, f"-{POSITION_LIMIT}..{POSITION_LIMIT}°")
        if rpm is not None:
            speed = self._speed_wire("move", rpm)
            return self._command(
                "position_speed", "move", direction=_direction(degrees), position=position, speed=speed
            )
        assert seconds is not None
        arrival = self._seconds_wire(seconds)
        return self._command(
            "accel_position", "move", direction=_direction(degrees), position=position, arrival_time=arrival
        )

    def make_run(self, rpm: float, ramp_seconds: float = RUN_RAMP) -> Command:
        """Speed command: signed RPM (CCW +), reached in ramp_seconds (§3)."""
        if rpm == 0:
            raise ValueOutOfRange(
                "run", "rpm", rpm, "a non-zero speed (speed 0 is invalid for run(): stop() stops, release() lets go)"
            )
        speed, arrival = self._speed_wire("run", abs(rpm)), self._seconds_wire(ramp_seconds)
        return self._command("accel_speed", "run", direction=_direction(rpm), speed=speed, arrival_time=arrival)

    def make_release(self) -> Command:
        return self._command("set_control", "release", control=1)

    def make_stop(self, ramp_seconds: float = 0.5) -> Command:
        """Speed 0 reached in ramp_seconds (§3 with speed 0: see stop()), in the motor's line."""
        arrival = self._seconds_wire(ramp_seconds)
        ramped = self._command("accel_speed", "stop", direction=0, speed=1, arrival_time=arrival)
        zero = SpeedZero if type(ramped) is AccelSpeed else _speed_zero_class(type(ramped))
        return zero(self.id, 0, 0, arrival)

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
            answer = yield from self.core.ask(self._request("request_position_mode", "a position move"))
            self._relative = answer.fields()["position_mode"] == 1
        return self._relative

    def _enable_if_released(self) -> Procedure[None]:
        """Control on if it is off (read once if unknown). The motion that follows waits out the
        busy window this starts (docs/protocol.md, Busy window, rule 5)."""
        released = self.core.control_released.get(self.id)
        if released is None:
            answer = yield from self.core.ask(self._request("request_control", "control on/off"))
            released = answer.fields()["control"] == 1
            self.core.control_released.setdefault(self.id, released)
        if released:
            yield from self.core.tell(self._command("set_control", "control on", control=0))

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
        command = self.make_move_to(degrees, rpm, seconds)  # refused before any I/O on a speed-only line
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
        self.make_move_to(degrees, rpm, seconds)  # checks the line has position commands, before any I/O
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
            at_rest = at_rest + 1 if there and abs(state.speed) < STOPPED_RPM else 0
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

    def run(self, rpm: float, ramp_seconds: float = RUN_RAMP) -> Procedure[None]:
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
        if not self.line.has("position_speed"):  # a speed-only line (SM) has no position to hold
            state = yield from self.read_state()
            if abs(state.speed) >= STOPPED_RPM:
                raise NotArrived(
                    f"ID {self.id}: still turning at {state.speed:g} RPM after speed 0 over {ramp_seconds:g} s "
                    "(this firmware ignores speed 0 and an SM cannot hold a position); release() lets it coast"
                )
            return state
        yield from self.hold()
        if (yield from self._position_mode_is_relative()):  # hold() only turned control on: a
            yield from self.core.tell(self.make_move_to(0.0, rpm=HOLD_RPM))  # step of 0 holds here
        return (yield from self.wait_until_arrived(STOP_SETTLE, tolerance=math.inf))

    def release(self) -> Procedure[None]:
        """Control off: the motor is no longer driven and coasts to a stop."""
        yield from self.core.tell(self.make_release())

    def hold(self) -> Procedure[None]:
        """Control on, holding the present position."""
        if not self.line.has("position_speed"):  # a speed-only line (SM): nothing to hold a position with
            raise InputError(_unsupported(self.line.key, self.line.title, self.id, "hold", "position_speed"))
        yield from self.core.tell(self._command("set_control", "hold", control=0))
        self._target = None
        if (yield from self._position_mode_is_relative()):
            return
        state = yield from self.read_state()
        yield from self.core.tell(self.make_move_to(state.device_position, rpm=HOLD_RPM))

    # -- feedback -------------------------------------------------------------
    def state_from(self, answer: Message, at: float | None = None, sign: int | None = None) -> MotorState:
        """A MotorState from a position feedback answer (also used by group reads), or, on a
        line without one (SM), from a speed feedback answer: position in its 0.1 deg, speed signed.
        `at`: when it was read (the bus clock), for the multi-turn tracking (nurimc.procedures.multiturn);
        `sign`: the speed's sign when known otherwise (speed feedback read just after)."""
        # every reading comes here: the fields by index, each scaled as units.from_wire does (a
        # wire integer / 10 or / 100 is exactly its round(raw * 0.1, 1) or round(raw * 0.01, 2):
        # division is correctly rounded; tests/client/test_units_and_tracking.py checks every value)
        signed, i_direction, i_position, i_speed, i_current, position_steps = _feedback(type(answer))
        direction = answer[i_direction]
        device = answer[i_position] / position_steps
        speed = answer[i_speed] / 10
        if direction == 1:  # signed_degrees: CW is negative
            device = -device
            if signed:
                speed = -speed
        if sign is not None and not signed:
            speed, signed = speed * sign, True
        sent = self.core.commands_sent
        told = sent.get(self.id, 0) + sent.get(BROADCAST_ID, 0) if sent else 0
        tracker = self.tracker
        position, uncertain, tracked = tracker.advance(device, speed * 6.0, at, signed, told)
        if not signed and tracker.sign < 0:
            speed = -speed
        return MotorState(
            self.id,
            position,
            device,
            speed,
            answer[i_current] / 10,
            "cw" if direction == 1 else "ccw",
            signed or tracked is not None or abs(speed) < STOPPED_RPM,
            uncertain,
        )

    def read_state(self) -> Procedure[MotorState]:
        """Position feedback (§19); a speed-only line (SM) has none and reads its speed feedback."""
        answer = yield from self.core.ask(self.state_request())
        at: float = yield Now()
        return self.state_from(answer, at)

    def state_request(self) -> Request:
        """The request read_state sends."""
        kept = self._state_request
        if kept is None:
            name = "request_position" if self.line.has("request_position") else "request_speed"
            kept = self._state_request = self._request(name, "a reading")
        return kept

    def read_speed(self) -> Procedure[float]:
        """Signed speed in RPM (CCW +) from speed feedback (§20)."""
        answer = yield from self.core.ask(self._request("request_speed", "a speed reading"))
        f = answer.fields()
        return signed_degrees(f["direction"], units.from_wire(f["speed"], 0.1))

    def ping(self) -> Procedure[bool]:
        yield from self.core.ask(self._request("request_ping", "ping"))
        return True

    def _setting(self, name: str, write: bool = False) -> Setting:
        """A setting this line can read (and, with `write`, write), or InputError."""
        s = setting(name)
        missing = s.request if not self.line.has(s.request) else None
        if write and missing is None and s.command is not None and not self.line.has(s.command):
            missing = s.command
        if missing is not None:
            raise InputError(_unsupported(self.line.key, self.line.title, self.id, f"the {s.name} setting", missing))
        return s

    # -- settings -------------------------------------------------------------
    def get(self, name: str) -> Procedure[float | int | str]:
        s = self._setting(name)
        answer = yield from self.core.ask(self._request(s.request, s.name))
        return self.setting_from(s, answer)

    def setting_from(self, s: Setting, answer: Message) -> float | int | str:
        """A setting's value from its answer (remembered for the motor)."""
        raw = answer.fields()[s.field]
        self._remember(s, raw)
        return s.to_physical(raw)

    def read_settings(self) -> Procedure[dict[str, float | int | str]]:
        """Every setting the product line has, reading each feedback request once."""
        answers: dict[str, Message] = {}
        out: dict[str, float | int | str] = {}
        for s in SETTINGS.values():
            if not self.line.has(s.request):
                continue  # e.g. an RSA has no rated speed, an SM no position gains
            if s.answer not in answers:
                answers[s.answer] = yield from self.core.ask(self._request(s.request, s.name))
            raw = answers[s.answer].fields()[s.field]
            self._remember(s, raw)
            out[s.name] = s.to_physical(raw)
        return out

    def set(self, name: str, value: object) -> Procedure[float | int | str]:
        """Write a setting in physical units and verify it by reading it back."""
        s = self._setting(name, write=True)
        if s.command is None:
            raise InputError(f"{s.name} is read-only")
        raw = s.to_wire(value)
        if s.field == "rated_current" and raw > self.profile.max_rated_current:
            raise ValueOutOfRange(
                s.name, "value", value, f"0.1..{self.profile.max_rated_current / 10} A for {self.profile.title}"
            )
        fields = {s.field: raw}
        if len(self.line.message_class(s.command).SPEC.fields) > 1:  # gains: written together, from a confirmed read
            current = yield from confirmed_answer(self.core, self._request(s.request, s.name))
            fields = {**current.fields(), s.field: raw}
        yield from self.write_verified(s, self._command(s.command, s.name, **fields), raw)
        return s.to_physical(raw)

    def write_verified(self, s: Setting, command: Command, raw: int) -> Procedure[None]:
        """Send a settings command, then read it back until every field it wrote matches.

        The core holds the read-back until the busy window has ended; a controller slower than
        its window is polled for one more window before the write is called failed."""
        yield from self.core.tell(command)
        self._remember(s, raw)
        got: int | None = None
        wrong: dict[str, tuple[int, int]] = {}
        give_up: float | None = None
        while True:
            try:
                answer = yield from self.core.ask(self._request(s.request, s.name), retries=0)
                got = answer.fields()[s.field]
                wrong = fields_differ(command, answer)
                if not wrong:
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
        others = {k: v for k, v in wrong.items() if k != s.field}
        if got == raw and others:  # what was asked for took, but a field written with it reads otherwise
            said = "it reads " + ", ".join(f"{k} {read} (wrote {wrote})" for k, (wrote, read) in others.items())
        raise SettingNotApplied(
            f"ID {self.id}: wrote {s.name} = {s.to_physical(raw)} but {said}; the change did not take "
            "(check the value is allowed for this product, then try again)"
        )

    def tune(
        self,
        loop: str = "position",
        goal: str | None = None,
        max_overshoot: float | None = None,
        max_settling: float | None = None,
        travel: float = 30.0,
        max_rpm: float = 30.0,
        max_current: float = 3.0,
        trials: int = 24,
        apply: bool = False,
    ) -> Procedure[TuneResult]:
        """Tune the position or speed loop's gains on the motor (nurimc.procedures.tuning, docs/tuning.md):
        small steps inside the envelope (travel deg around here, max rpm, max current A); the
        starting gains are written back unless `apply`, and on any error or interruption."""
        from .tuning import tune

        return (
            yield from tune(self, loop, goal, max_overshoot, max_settling, travel, max_rpm, max_current, trials, apply)
        )

    def _remember(self, s: Setting, raw: int) -> None:
        if s.name == "response-time":
            self.core.response_times[self.id] = raw * 100e-6
        elif s.name == "position-mode":
            self._relative = raw == 1
        elif s.name == "control":
            self.core.control_released[self.id] = raw == 1


def _get_in_place(bus: Any, motor: MotorProcedures, name: str) -> float | int | str:
    """MotorProcedures.get through the bus's single-request call (drivers/fastpath.py)."""
    s = motor._setting(name)
    value: float | int | str = bus._request_then(motor._request(s.request, s.name), lambda a: motor.setting_from(s, a))
    return value


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

    move_to = HandleCall(MotorProcedures.move_to)
    move_by = HandleCall(MotorProcedures.move_by)
    run = HandleCall(MotorProcedures.run)
    wait_until_arrived = HandleCall(MotorProcedures.wait_until_arrived)
    stop = HandleCall(MotorProcedures.stop)
    release = HandleCall(MotorProcedures.release)
    hold = HandleCall(MotorProcedures.hold)
    read_state = HandleCall(MotorProcedures.read_state, lambda bus, m: bus._read_then(m.state_request(), m.state_from))
    read_speed = HandleCall(MotorProcedures.read_speed)
    ping = HandleCall(MotorProcedures.ping)
    get = HandleCall(MotorProcedures.get, lambda bus, m, name: _get_in_place(bus, m, name))
    set = HandleCall(MotorProcedures.set)
    read_settings = HandleCall(MotorProcedures.read_settings)
    tune = HandleCall(MotorProcedures.tune)


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
