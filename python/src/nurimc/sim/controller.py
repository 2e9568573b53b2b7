"""One simulated controller: settings, servo and the protocol (what it obeys and answers).

Sign convention: CCW is positive. A command's direction byte gives the sign of its position
(absolute mode: CCW 90° is +90°, CW 90° is -90°; relative mode: the sign of the step) or
speed. Feedback reports the magnitude and that sign the same way. Control direction CW
mirrors the controller's idea of positive, so commands and feedback both flip.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from ..protocol import MESSAGES, PRODUCTS, Answer, Message
from ..protocol import messages as m
from ..protocol.errors import EncodeError
from ..protocol.lines import SIMULATED_LINES
from ..protocol.lines import line as line_named
from ..protocol.message import check_value
from . import servo as sv
from .motor import ACCEL_PER_AMP, COULOMB, VISCOUS
from .plant import Plant
from .servo import Mode, Servo
from .settings import Settings, check_product

log = logging.getLogger("nurimc.sim")

EEPROM_TIME = 0.05  # s a settings write keeps the controller busy (field notes: 50-300 ms)
FIRMWARE_VERSION = 1
POSITION_WRAP = 65536  # the position register wraps at 655.36 deg (0.01 deg units)
FIELD_MAX = 0xFFFD  # 16-bit fields stop at FFFD

# Commands that write EEPROM (and so make the controller busy). Motion and position reset do not.
SETTINGS_COMMANDS = (
    m.SetPositionGains,
    m.SetSpeedGains,
    m.SetId,
    m.SetBaud,
    m.SetResponseTime,
    m.SetRatedSpeed,
    m.SetResolution,
    m.SetRatio,
    m.SetControl,
    m.SetPositionMode,
    m.SetDirection,
    m.FactoryReset,
)
SPEED_COMMANDS = (m.PositionSpeed, m.AccelSpeed)


@dataclass
class Reply:
    """An answer frame and when (bus time) the controller starts sending it."""

    start: float
    frame: bytes
    baud: int
    controller: SimController


def counts_per_motor_turn(product: str, resolution: int) -> int:
    """Hall steps per motor turn on a BLMC-H (poles x 3); encoder edges (pulses x 4, quadrature)
    on an MC and on the lines with no resolution setting (RSA, RSAVW, SA, SM: actuators with an
    encoder; the simulator's --resolution sets their pulses, docs/simulator.md)."""
    return resolution * 3 if product == "blmc-h" else resolution * 4


def _signed(direction: int, magnitude: float) -> float:
    return -magnitude if direction else magnitude


def _magnitude_and_direction(value: float, scale: float, wrap: int | None) -> tuple[int, int]:
    units = round(abs(value) / scale)
    if wrap is not None:
        units %= wrap
    return (1 if value < 0 and units else 0), min(units, FIELD_MAX)


class SimController:
    """A controller on the bus. `receive` takes the bytes it hears; `replies` are what it sends."""

    def __init__(
        self,
        settings: Settings,
        product: str,
        slot: int,
        on_settings_changed: Callable[[], None] | None = None,
        eeprom_time: float = EEPROM_TIME,
        speed_zero: str = "ignore",
        factory_defaults: dict[str, int] | None = None,
    ) -> None:
        self.product = check_product(product)
        # the table this controller speaks (spec/lines.json); its frames are read with it
        self.line = SIMULATED_LINES[product]
        self._line = line_named(self.line)
        self.echo = 0  # RSAVW echo mode (1 on): stored and read back; what it does is not documented
        self.speed_zero = speed_zero
        self.factory_defaults = factory_defaults
        self.settings = settings
        self.slot = slot
        self.eeprom_time = eeprom_time
        self.busy_until = -1.0
        self.servo = Servo()
        self.clock_origin: float | None = None  # bus time of servo time 0
        self._on_settings_changed = on_settings_changed
        self.frames_received = 0
        self.frames_ignored_busy = 0
        self.restored = False  # its settings came from a --state directory: kept as stored
        self.apply_settings()
        if settings.control:
            self.servo.release()

    # --- identity ---------------------------------------------------------------------------
    @property
    def id(self) -> int:
        return self.settings.id

    @property
    def baud(self) -> int:
        return self.settings.baud

    def __repr__(self) -> str:
        return f"SimController(id={self.id}, baud={self.baud}, product={self.product!r})"

    # --- model ------------------------------------------------------------------------------
    @property
    def counts_per_output_turn(self) -> float:
        return counts_per_motor_turn(self.product, self.settings.resolution) * self.settings.ratio / 10

    def apply_settings(self) -> None:
        """Push the settings into the servo's gains and limits."""
        s, servo = self.settings, self.servo
        gear = s.ratio / 10
        servo.limits.max_speed = s.rated_speed * 6.0 / gear
        # the motor's inertia and friction, seen through the gearbox (see motor.py)
        plant = servo.plant  # a plant's inertia and friction as multiples of today's (sim/plant.py)
        servo.limits.accel_per_amp = ACCEL_PER_AMP / gear / plant.inertia
        servo.limits.coulomb = COULOMB * plant.coulomb / gear / plant.inertia
        servo.limits.viscous = VISCOUS * plant.viscous / plant.inertia
        servo.limits.quantum = 360.0 / self.counts_per_output_turn
        product_max = PRODUCTS[self.product].max_rated_current
        pg, sg = servo.position_gains, servo.speed_gains
        pg.kp, pg.ki, pg.kd = (
            s.position_kp * sv.POSITION_KP,
            s.position_ki * sv.POSITION_KI,
            s.position_kd * sv.POSITION_KD,
        )
        pg.current_limit = min(s.position_rated_current, product_max) / 10
        # the speed loop acts on the motor's speed (gear x the output's): ratio-independent dynamics
        sg.kp, sg.ki, sg.kd = (
            s.speed_kp * sv.SPEED_KP * gear,
            s.speed_ki * sv.SPEED_KI * gear,
            s.speed_kd * sv.SPEED_KD * gear,
        )
        sg.current_limit = min(s.speed_rated_current, product_max) / 10
        servo.static = False

    def set_plant(self, plant: Plant) -> None:
        """Stand for another motor and load (sim/plant.py); the gains keep their scaling."""
        self.servo.set_plant(plant, seed=self.slot)
        self.apply_settings()

    def advance_to(self, now: float) -> None:
        """Step the physics up to bus time `now`."""
        if self.clock_origin is None:
            self.clock_origin = now - self.servo.time
        self.servo.advance(now - self.clock_origin - self.servo.time)

    def _sense(self) -> float:
        return -1.0 if self.settings.direction else 1.0

    def logical_angle(self) -> float:
        """The position the controller reports, in degrees (quantised, in its own sense)."""
        return self.servo.measured_angle() * self._sense()

    def _register_base(self) -> float:
        """Where the position register's present turn of 655.36 deg starts, in the controller's sense.

        The register is what the feedback reports (wrapped); an absolute target is a value for
        it, so the motor goes from the register's present value to the target: a hold at the
        reported position stays put after any number of turns, as on a register-based controller."""
        logical = self.logical_angle()
        direction, units = _magnitude_and_direction(logical, 0.01, POSITION_WRAP)
        return logical - _signed(direction, units / 100)

    def logical_speed(self) -> float:
        """deg/s in the controller's sense."""
        return self.servo.motor.speed * self._sense()

    def reported_current(self) -> int:
        """Feedback current in 100 mA: the magnitude of the applied current, clamped to the rating."""
        return min(round(abs(self.servo.motor.current) * 10), 254)

    # --- protocol ---------------------------------------------------------------------------
    def take(self, message: Message, now: float) -> Reply | None:
        """A frame addressed to us (or broadcast), whole at bus time `now`: obey or answer it,
        unless it cannot be taken (logged with the reason).

        A message of another line comes in that line's class; where MC has a message of the
        same name (same fields, same meaning) it is handled as MC's, and its answer goes out
        in the line's own class (the line's mode byte)."""
        self.frames_received += 1
        if message.LINE != "mc" and message.name in MESSAGES:
            message = MESSAGES[message.name](*message)
        problem = self._out_of_range(message)
        if problem is not None:
            log.debug("id %d ignores %s: %s", self.id, message, problem)
            return None
        if now < self.busy_until:
            self.frames_ignored_busy += 1
            log.debug(
                "id %d ignores %s: busy writing settings (EEPROM) for %.1f ms more",
                self.id,
                message,
                (self.busy_until - now) * 1000,
            )
            return None
        if isinstance(message, Answer):
            log.debug("id %d ignores %s: an answer, which only controllers send", self.id, message)
            return None
        return self.handle(message, now)

    def _out_of_range(self, message: Message) -> str | None:
        """Why a field is outside the document's range (speed 0, baud index 18, Kp 0, ...), or None.
        Speed 0 in a motion command is taken when the product's rule is "stop"."""
        spec = message.SPEC
        for f in spec.fields:
            value = getattr(message, f.name)
            if f.name == "speed" and value == 0 and isinstance(message, SPEED_COMMANDS):
                if self.speed_zero == "stop":
                    continue
                return "speed 0 is outside the document's range 1-65533 (profile rule speed_zero=ignore)"
            try:
                check_value(spec, f, value)
            except EncodeError as exc:
                return f"{f.name} {value} is outside the document's range ({exc})"
        return None

    def handle(self, message: Message, now: float) -> Reply | None:
        """Obey a command or answer a request addressed to us (or broadcast)."""
        self.advance_to(now)
        if isinstance(message, SETTINGS_COMMANDS):
            self._write_setting(message)
            self.busy_until = now + self.eeprom_time
            if self._on_settings_changed is not None:
                self._on_settings_changed()
            return None
        answer = self._answer(message) if message.LINE == "mc" else self._line_answer(message)
        if answer is None:
            self._move(message)
            return None
        if self.line != answer.LINE:  # MC's answer class: sent with this line's mode byte
            answer = self._line.classes[answer.name](*answer)
        start = now + self.settings.response_time * 100e-6
        return Reply(start, answer.encode(), self.baud, self)

    def _line_answer(self, msg: Message) -> Message | None:
        """Requests only other lines have (RSAVW absolute encoder and echo, SM README firmware)."""
        cls = self._line.classes
        if msg.name == "request_absolute_position":
            # an absolute encoder reads the shaft's angle within one turn (0.01 deg; not documented
            # beyond the vendor reader's layout): the present angle modulo 360 deg
            angle = round(self.logical_angle() * 100) % 36000
            return cls["absolute_position"](self.id, 0, angle)
        if msg.name == "request_echo":
            return cls["echo"](self.id, self.echo)
        if msg.name == "request_firmware_a6":
            return cls["firmware_a6"](self.id, FIRMWARE_VERSION)
        return None

    def _write_setting(self, msg: Message) -> None:
        s = self.settings
        if isinstance(msg, m.SetPositionGains):
            s.position_kp, s.position_ki, s.position_kd = msg.kp, msg.ki, msg.kd
            s.position_rated_current = msg.rated_current
        elif isinstance(msg, m.SetSpeedGains):
            s.speed_kp, s.speed_ki, s.speed_kd = msg.kp, msg.ki, msg.kd
            s.speed_rated_current = msg.rated_current
        elif isinstance(msg, m.SetId):
            s.id = msg.new_id
        elif isinstance(msg, m.SetBaud):
            s.baud_index = msg.baud_index
        elif isinstance(msg, m.SetResponseTime):
            s.response_time = msg.response_time
        elif isinstance(msg, m.SetRatedSpeed):
            s.rated_speed = msg.rated_speed
        elif isinstance(msg, m.SetResolution):
            s.resolution = msg.resolution
        elif isinstance(msg, m.SetRatio):
            s.ratio = msg.ratio
        elif isinstance(msg, m.SetControl):
            s.control = msg.control
            if msg.control:
                self.servo.release()
            else:
                self.servo.hold()
        elif isinstance(msg, m.SetPositionMode):
            s.position_mode = msg.position_mode
        elif isinstance(msg, m.SetDirection):
            if msg.direction != s.direction:
                s.direction = msg.direction
                # the same physical place, now seen mirrored: keep holding it
                if self.servo.mode is Mode.POSITION:
                    self.servo.hold()
        elif isinstance(msg, m.FactoryReset):
            fresh = Settings.factory(self.product, self.factory_defaults)
            for name, value in fresh.to_dict().items():
                setattr(s, name, value)
            self.servo.hold()
        self.apply_settings()

    def _move(self, msg: Message) -> None:
        servo, sense = self.servo, self._sense()
        if isinstance(msg, m.ResetPosition):
            servo.zero()
            return
        if msg.name == "set_echo":  # RSAVW: kept and read back (it is not said what echo does)
            self.echo = msg.fields()["echo"]
            return
        if self.settings.control:  # control off: motion commands are ignored until control on
            log.debug("id %d ignores %s: control is off (set_control with control 0 turns it on)", self.id, msg)
            return
        if msg.name == "open_loop":  # SA: drive at a duty, no loop; duty 0 lets the motor go
            fields = msg.fields()
            duty = fields["duty"]
            if duty == 0:
                servo.release()
            else:
                top = servo.limits.max_speed * duty / 10000
                servo.ramp_speed(_signed(fields["direction"], top) * sense, 0.1)
            return
        if isinstance(msg, m.PositionSpeed) and msg.speed == 0:  # taken only under speed_zero=stop
            servo.hold()  # stop: hold the place it has reached
            return
        if isinstance(msg, (m.PositionSpeed, m.AccelPosition)):
            amount = _signed(msg.direction, msg.position / 100)
            if self.settings.position_mode:  # relative: a step from where the last move was going
                base = servo.target if servo.mode is Mode.POSITION else servo.measured_angle()
                target = base + amount * sense
            else:  # absolute: a value for the position register, which wraps as the feedback does
                target = (self._register_base() + amount) * sense
            if isinstance(msg, m.PositionSpeed):
                servo.move_at_speed(target, msg.speed / 10 * 6)
            else:
                servo.move_in_time(target, msg.arrival_time / 10)
        elif isinstance(msg, m.AccelSpeed) and msg.speed == 0:  # taken only under speed_zero=stop
            servo.stop(msg.arrival_time / 10)  # decelerate over the arrival time, then hold
        elif isinstance(msg, m.AccelSpeed):
            servo.ramp_speed(_signed(msg.direction, msg.speed / 10 * 6) * sense, msg.arrival_time / 10)

    def _answer(self, msg: Message) -> Message | None:
        s, i = self.settings, self.id
        if isinstance(msg, m.RequestPing):
            return m.Ping(i)
        if isinstance(msg, m.RequestPosition):
            d, pos = _magnitude_and_direction(self.logical_angle(), 0.01, POSITION_WRAP)
            _, speed = _magnitude_and_direction(self.logical_speed(), 0.6, None)
            return m.PositionFeedback(i, d, pos, speed, self.reported_current())
        if isinstance(msg, m.RequestSpeed):
            d, speed = _magnitude_and_direction(self.logical_speed(), 0.6, None)
            # 0.1 deg as printed (erratum 6): the same wrapped angle in tenths
            _, pos = _magnitude_and_direction(self.logical_angle(), 0.01, POSITION_WRAP)
            return m.SpeedFeedback(i, d, speed, pos // 10, self.reported_current())
        if isinstance(msg, m.RequestPositionGains):
            return m.PositionGains(i, s.position_kp, s.position_ki, s.position_kd, s.position_rated_current)
        if isinstance(msg, m.RequestSpeedGains):
            return m.SpeedGains(i, s.speed_kp, s.speed_ki, s.speed_kd, s.speed_rated_current)
        if isinstance(msg, m.RequestResponseTime):
            return m.ResponseTime(i, s.response_time)
        if isinstance(msg, m.RequestRatedSpeed):
            return m.RatedSpeed(i, s.rated_speed)
        if isinstance(msg, m.RequestResolution):
            return m.Resolution(i, s.resolution)
        if isinstance(msg, m.RequestRatio):
            return m.Ratio(i, s.ratio)
        if isinstance(msg, m.RequestControl):
            return m.Control(i, s.control)
        if isinstance(msg, m.RequestPositionMode):
            return m.PositionMode(i, s.position_mode)
        if isinstance(msg, m.RequestDirection):
            return m.Direction(i, s.direction)
        if isinstance(msg, m.RequestFirmware):
            return m.Firmware(i, FIRMWARE_VERSION)
        return None
