"""A motor per controller ID, in physical units: degrees, RPM, amperes, seconds.

`MotorProcedures` holds the logic as procedures (sans-I/O); `Motor` runs them on a sync Bus,
`nurimc.client.aio.AsyncMotor` on an AsyncBus. Builders (`make_*`) return the command
without sending it, for batches: `bus.send(*(m.make_run(30) for m in motors))`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .client.actions import Procedure, Wait
from .client.core import BusCore
from .errors import NoAnswer, SettingNotApplied
from .multiturn import TurnTracker, signed_degrees
from .protocol import (
    PRODUCTS,
    AccelPosition,
    AccelSpeed,
    Command,
    FieldRangeError,
    Message,
    PositionFeedback,
    PositionSpeed,
    ProductSpec,
    RequestPosition,
    RequestSpeed,
    SetControl,
    SpeedFeedback,
    make_command,
    make_request,
    message_class,
    units,
)
from .settings import SETTINGS, Setting, setting

if TYPE_CHECKING:
    from .client.sync import Bus

POSITION_LIMIT = 655.33  # the largest position a command can carry, degrees
EEPROM_SETTLE = 0.05  # a settings write keeps the controller busy 50-300 ms (field notes)
VERIFY_WINDOW = 0.4  # how long a read-back may keep failing while the EEPROM write finishes
HOLD_RPM = 10.0


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


class MotorProcedures:
    """Everything a motor handle does, as procedures on a BusCore."""

    def __init__(self, core: BusCore, device_id: int, product: str = "mc") -> None:
        if product not in PRODUCTS:
            raise ValueError(f"unknown product {product!r}; products: {', '.join(PRODUCTS)}")
        self.core = core
        self.id = device_id
        self.profile: ProductSpec = PRODUCTS[product]
        self.tracker = TurnTracker()
        self._relative: bool | None = None  # position mode, read before the first move
        self._released = False

    # -- builders (no I/O) --------------------------------------------------
    def make_move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> Command:
        """Position command for a signed target (CCW +). Give rpm (§1) or arrival seconds (§2)."""
        if (rpm is None) == (seconds is None):
            raise ValueError("give exactly one of rpm= (speed) or seconds= (arrival time)")
        if abs(degrees) > POSITION_LIMIT:
            raise FieldRangeError("move", "degrees", degrees, f"-{POSITION_LIMIT}..{POSITION_LIMIT} deg")
        position = units.degrees_to_wire(abs(degrees))
        if rpm is not None:
            return PositionSpeed(self.id, _direction(degrees), position, self._speed_wire("move", rpm))
        assert seconds is not None
        return AccelPosition(self.id, _direction(degrees), position, self._seconds_wire(seconds))

    def make_run(self, rpm: float, ramp_seconds: float = 0.1) -> Command:
        """Speed command: signed RPM (CCW +), reached in ramp_seconds (§3)."""
        if rpm == 0:
            raise FieldRangeError(
                "run", "rpm", rpm, "a non-zero speed (speed 0 is invalid: use release() or hold() to stop)"
            )
        return AccelSpeed(self.id, _direction(rpm), self._speed_wire("run", abs(rpm)), self._seconds_wire(ramp_seconds))

    def make_release(self) -> Command:
        return SetControl(self.id, 1)

    def _speed_wire(self, what: str, rpm: float) -> int:
        raw = units.rpm_to_wire(abs(rpm))
        if not 1 <= raw <= 65533:
            raise FieldRangeError(what, "rpm", rpm, "0.1..6553.3 rpm")
        return raw

    @staticmethod
    def _seconds_wire(seconds: float) -> int:
        raw = units.seconds_to_wire(seconds)
        if not 1 <= raw <= 255:
            raise FieldRangeError("motion", "seconds", seconds, "0.1..25.5 s")
        return raw

    # -- motion ---------------------------------------------------------------
    def _position_mode_is_relative(self) -> Procedure[bool]:
        if self._relative is None:
            answer = yield from self.core.ask(make_request("request_position_mode", self.id))
            self._relative = answer.fields()["position_mode"] == 1
        return self._relative

    def _enable_if_released(self) -> Procedure[None]:
        if self._released:
            yield from self.core.tell(SetControl(self.id, 0))
            self._released = False

    def move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> Procedure[None]:
        """Go to an absolute signed position (in the device's frame, ±655.33 deg)."""
        command = self.make_move_to(degrees, rpm, seconds)
        if (yield from self._position_mode_is_relative()):
            state = yield from self.read_state()
            command = self.make_move_to(degrees - state.device_position, rpm, seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)

    def move_by(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> Procedure[None]:
        """Move by a signed amount from where the motor is."""
        if (yield from self._position_mode_is_relative()):
            command = self.make_move_to(degrees, rpm, seconds)
        else:
            state = yield from self.read_state()
            command = self.make_move_to(state.device_position + degrees, rpm, seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)

    def run(self, rpm: float, ramp_seconds: float = 0.1) -> Procedure[None]:
        command = self.make_run(rpm, ramp_seconds)
        yield from self._enable_if_released()
        yield from self.core.tell(command)

    def release(self) -> Procedure[None]:
        """Control off: the motor is no longer driven and coasts to a stop."""
        yield from self.core.tell(self.make_release())
        self._released = True

    def hold(self) -> Procedure[None]:
        """Control on, holding the present position."""
        yield from self.core.tell(SetControl(self.id, 0))
        self._released = False
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
            raise ValueError(f"{s.name} is read-only")
        raw = s.to_wire(value)
        if s.field == "rated_current" and raw > self.profile.max_rated_current:
            raise FieldRangeError(
                s.name, "value", value, f"0.1..{self.profile.max_rated_current / 10} A for {self.profile.title}"
            )
        fields = {s.field: raw}
        if len(message_class(s.command).SPEC.fields) > 1:  # gains: written together
            current = yield from self.core.ask(make_request(s.request, self.id))
            fields = {**current.fields(), s.field: raw}
        yield from self.write_verified(s, make_command(s.command, self.id, **fields), raw)
        return s.to_physical(raw)

    def write_verified(self, s: Setting, command: Command, raw: int) -> Procedure[None]:
        """Send a settings command, then read it back until it matches or the EEPROM window ends."""
        yield from self.core.tell(command)
        self._remember(s, raw)
        yield Wait(EEPROM_SETTLE)
        got: int | None = None
        waited = EEPROM_SETTLE
        while True:
            try:
                answer = yield from self.core.ask(make_request(s.request, self.id), retries=0)
                got = answer.fields()[s.field]
                if got == raw:
                    return
            except NoAnswer:
                pass
            if waited >= VERIFY_WINDOW:
                break
            yield Wait(0.05)
            waited += 0.05
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
            self._released = raw == 1


class Motor:
    """A motor on a sync Bus. Every method sends now; make_* methods build without sending."""

    def __init__(self, bus: Bus, device_id: int, product: str = "mc") -> None:
        self.bus = bus
        self.procedures = MotorProcedures(bus.core, device_id, product)
        self.id = device_id
        self.make_move_to = self.procedures.make_move_to
        self.make_run = self.procedures.make_run
        self.make_release = self.procedures.make_release

    def __repr__(self) -> str:
        return f"Motor(id={self.id}, product={self.procedures.profile.key!r})"

    def move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> None:
        self.bus.run(self.procedures.move_to(degrees, rpm, seconds))

    def move_by(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> None:
        self.bus.run(self.procedures.move_by(degrees, rpm, seconds))

    def run(self, rpm: float, ramp_seconds: float = 0.1) -> None:
        self.bus.run(self.procedures.run(rpm, ramp_seconds))

    def release(self) -> None:
        self.bus.run(self.procedures.release())

    def hold(self) -> None:
        self.bus.run(self.procedures.hold())

    def read_state(self) -> MotorState:
        return self.bus.run(self.procedures.read_state())

    def read_speed(self) -> float:
        return self.bus.run(self.procedures.read_speed())

    def ping(self) -> bool:
        return self.bus.run(self.procedures.ping())

    def get(self, name: str) -> Any:
        return self.bus.run(self.procedures.get(name))

    def set(self, name: str, value: object) -> Any:
        return self.bus.run(self.procedures.set(name, value))

    def read_settings(self) -> dict[str, Any]:
        return self.bus.run(self.procedures.read_settings())
