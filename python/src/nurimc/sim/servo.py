"""The controller's servo: motion references (the three motion commands) and a cascaded PID.

Position loop (gains of section 4) -> speed reference; speed loop (gains of section 5) ->
current, clamped to the rated current -> motor. The u8 gains are scaled to physical gains
(below) so that the product defaults give a brisk, well-damped response and changing a
gain visibly changes the step response.

A real controller closes its loops on the motor's encoder or hall sensors, before the
gearbox; the controller applies the speed gains to the motor's speed (n times the output's
speed at n:1), so the loops behave the same at every ratio (see SimController.apply_settings).
"""

from __future__ import annotations

import math
import random
from collections import deque
from dataclasses import dataclass
from enum import Enum

from .motor import ACCEL_PER_AMP, COULOMB, VISCOUS, ShaftState, step_motor
from .plant import Plant

DT = 0.001  # s, the fixed physics step

# u8 gain -> physical gain
POSITION_KP = 0.4  # (deg/s) per deg
POSITION_KI = 0.5  # (deg/s) per deg*s
POSITION_KD = 0.002  # (deg/s) per deg/s
SPEED_KP = 0.0003  # A per deg/s
SPEED_KI = 0.003  # A per deg
SPEED_KD = 0.000002  # A per deg/s^2

# The share of the rated current the position loop plans to brake with (the rest rejects
# disturbances and the speed loop's lag).
BRAKING_SHARE = 0.6


class Mode(Enum):
    OFF = "off"  # control off: no current, the motor coasts
    POSITION = "position"  # follow a position reference
    SPEED = "speed"  # follow a speed reference


@dataclass
class Gains:
    kp: float
    ki: float
    kd: float
    current_limit: float  # A


@dataclass
class Limits:
    max_speed: float  # deg/s at the output shaft
    accel_per_amp: float  # deg/s^2 per A at the output shaft
    quantum: float  # deg: one encoder / hall step at the output shaft
    coulomb: float = COULOMB  # deg/s^2 of dry friction at the output shaft
    viscous: float = VISCOUS  # 1/s, the coasting decay rate


class Servo:
    """Motion state of one controller; `advance(dt_total)` steps it at the fixed DT."""

    def __init__(self) -> None:
        self.motor = ShaftState()
        self.mode = Mode.POSITION
        self.position_gains = Gains(20.0, 0.0, 0.02, 5.0)
        self.speed_gains = Gains(0.009, 0.03, 0.0, 5.0)
        self.limits = Limits(18_000.0, ACCEL_PER_AMP, 22.5)
        # position reference: a move at constant speed or a smooth profile
        self.target = 0.0
        self.ref = 0.0
        self.ref_speed = 0.0  # the constant speed of a 01 move (deg/s, magnitude)
        self.profile: tuple[float, float, float, float] | None = None  # start, end, t0, duration
        # speed reference: a linear ramp
        self.speed_ref = 0.0
        self.ramp: tuple[float, float, float, float] | None = None  # from, to, t0, duration
        self.time = 0.0  # s, the servo's own time since it was made
        self._pos_integral = 0.0
        self._speed_integral = 0.0
        self._last_speed_error = 0.0
        self.static = False  # nothing will change until a new command arrives
        self.hold_after_ramp = False  # a stop (speed 0): hold the place reached when the ramp ends
        # plant parameters beyond inertia and friction (sim/plant.py): play, reading noise, dead time
        self.plant = Plant()
        self._output = 0.0  # deg, the output side of the play (read only when backlash > 0)
        self._noise = 0.0  # deg, this step's noise on the reading
        self._noise_rng = random.Random(0)
        self._pending: deque[float] = deque()  # currents on their way through the drive's dead time

    def set_plant(self, plant: Plant, seed: int = 0) -> None:
        """Backlash, noise and delay of `plant` (inertia and friction go into the limits:
        SimController.apply_settings)."""
        self.plant = plant
        self._output = self.motor.angle
        self._noise = 0.0
        self._noise_rng = random.Random(seed)
        self._pending = deque([0.0] * round(plant.delay / DT))
        self.static = False

    # --- measurements as the controller sees them -----------------------------------------
    def measured_angle(self) -> float:
        q = self.limits.quantum
        angle = self._output if self.plant.backlash > 0.0 else self.motor.angle
        return round((angle + self._noise) / q) * q

    # --- commands --------------------------------------------------------------------------
    def hold(self) -> None:
        """Stay where the motor is (control on, or after a position reset)."""
        here = self.measured_angle()
        self.mode = Mode.POSITION
        self.target = self.ref = here
        self.profile = None
        self.ref_speed = 0.0
        self._pos_integral = 0.0
        self._speed_integral = 0.0
        self.static = False

    def release(self) -> None:
        self.mode = Mode.OFF
        self.profile = self.ramp = None
        self.static = False

    def move_at_speed(self, target: float, speed: float) -> None:
        """Section 1: go to `target` at `speed` (deg/s, clamped to the rated speed)."""
        if self.mode is not Mode.POSITION:
            self.ref = self.motor.angle
            self._pos_integral = 0.0
        self.mode = Mode.POSITION
        self.profile = None
        self.target = target
        self.ref_speed = min(abs(speed), self.limits.max_speed)
        self.static = False

    def move_in_time(self, target: float, duration: float) -> None:
        """Section 2: reach `target` in `duration` s along a smooth (cubic) profile."""
        start = self.ref if self.mode is Mode.POSITION else self.motor.angle
        self.mode = Mode.POSITION
        self.target = target
        self.profile = (start, target, self.time, max(duration, DT))
        self.static = False

    def ramp_speed(self, speed: float, duration: float) -> None:
        """Section 3: ramp the speed to `speed` (deg/s, signed) in `duration` s."""
        self.hold_after_ramp = False
        speed = max(-self.limits.max_speed, min(self.limits.max_speed, speed))
        start = self.speed_ref if self.mode is Mode.SPEED else self.motor.speed
        if self.mode is not Mode.SPEED:
            self._speed_integral = 0.0
        self.mode = Mode.SPEED
        self.profile = None
        self.ramp = (start, speed, self.time, max(duration, DT))
        self.static = False

    def stop(self, duration: float) -> None:
        """Speed 0 as the vendor's simulator takes it: decelerate to a stop over `duration` s,
        then hold the place reached (so nothing creeps on at a residual speed)."""
        self.ramp_speed(0.0, duration)
        self.hold_after_ramp = True

    def zero(self) -> None:
        """Section 15: the current position becomes zero (the motor keeps what it was doing)."""
        offset = self.measured_angle()
        self.motor.angle -= offset
        self._output -= offset
        self.target -= offset
        self.ref -= offset
        if self.profile is not None:
            a, b, t0, d = self.profile
            self.profile = (a - offset, b - offset, t0, d)

    # --- stepping --------------------------------------------------------------------------
    def advance(self, seconds: float) -> None:
        """Advance by `seconds` of simulated time (whole steps; a static servo jumps)."""
        steps = int(seconds / DT + 1e-9)
        if steps <= 0:
            return
        if self.static:
            self.time += steps * DT
            return
        for _ in range(steps):
            self._step()
            if self.static:
                self.time += (steps - 1 - _) * DT
                return

    def _step(self) -> None:
        m, lim = self.motor, self.limits
        self.time += DT
        if self.hold_after_ramp and (self.mode is not Mode.SPEED or self.ramp is None):
            self.hold_after_ramp = False
            if self.mode is Mode.SPEED:
                self.hold()
        if self.mode is Mode.OFF:
            step_motor(m, self._through_drive(0.0), lim.accel_per_amp, lim.coulomb, DT, lim.viscous)
            self._sense_plant()
            self.static = m.speed == 0.0 and not any(self._pending)
            return
        if self.mode is Mode.POSITION:
            feedforward = self._position_reference()
            g = self.position_gains
            error = self.ref - self.measured_angle()
            if abs(error) <= lim.quantum / 2 + 1e-9:  # settle rule: within half a count of the reference
                error = 0.0  # is there (a target between two counts would otherwise hunt between them)
            # PID on the error alone (no velocity feedforward): the gains shape the response
            speed_ref = g.kp * error + g.ki * self._pos_integral + g.kd * (feedforward - m.speed)
            if abs(speed_ref) < lim.max_speed:
                self._pos_integral += error * DT  # integrate only while not saturated
            limit = g.current_limit
            cap = self._speed_cap(limit)
            speed_ref = max(-cap, min(cap, speed_ref))
        else:
            speed_ref = self._speed_reference()
            error = 0.0
            limit = self.speed_gains.current_limit
        s = self.speed_gains
        speed_error = speed_ref - m.speed
        derivative = (speed_error - self._last_speed_error) / DT
        self._last_speed_error = speed_error
        current = s.kp * speed_error + s.ki * self._speed_integral + s.kd * derivative
        if abs(current) < limit:
            self._speed_integral += speed_error * DT
        current = max(-limit, min(limit, current))
        step_motor(m, self._through_drive(current), lim.accel_per_amp, lim.coulomb, DT, lim.viscous)
        self._sense_plant()
        self.static = (
            m.speed == 0.0
            and not any(self._pending)
            and self.plant.noise == 0.0
            and speed_ref == 0.0
            and error == 0.0
            and self.profile is None
            and self.ramp is None
            and (self.mode is Mode.SPEED or self.ref == self.target)
        )

    def _through_drive(self, current: float) -> float:
        """The current applied now: the one asked for `plant.delay` seconds ago."""
        if not self._pending:
            return current
        self._pending.append(current)
        return self._pending.popleft()

    def _sense_plant(self) -> None:
        """The output side of the play follows the motor only once the play is taken up; a new
        sample of the reading's noise."""
        p = self.plant
        if p.backlash > 0.0:
            half = p.backlash / 2
            self._output = min(max(self._output, self.motor.angle - half), self.motor.angle + half)
        if p.noise > 0.0:
            self._noise = self._noise_rng.gauss(0.0, p.noise)

    def _speed_cap(self, current_limit: float) -> float:
        """The fastest the position loop may ask for: the rated speed, a 01 move's speed, and a
        speed the motor can still brake from before the target with part of its current (so a
        current-limited motor, e.g. behind a large gearbox, arrives instead of overshooting)."""
        lim = self.limits
        cap = lim.max_speed
        if self.profile is None and self.ref_speed > 0.0:
            cap = min(cap, self.ref_speed)
        braking = BRAKING_SHARE * current_limit * lim.accel_per_amp + lim.coulomb
        distance = abs(self.target - self.motor.angle) + lim.quantum
        return min(cap, math.sqrt(2.0 * braking * distance))

    def _position_reference(self) -> float:
        """Move the position reference one step; return its speed (the feedforward)."""
        if self.profile is not None:
            start, end, t0, duration = self.profile
            tau = (self.time - t0) / duration
            if tau >= 1.0:
                self.profile = None
                self.ref = end
                return 0.0
            tau = max(tau, 0.0)
            self.ref = start + (end - start) * (3 * tau * tau - 2 * tau * tau * tau)
            return (end - start) * (6 * tau - 6 * tau * tau) / duration
        gap = self.target - self.ref
        if gap == 0.0:
            return 0.0
        stride = self.ref_speed * DT
        if abs(gap) <= stride:
            self.ref = self.target
            return 0.0
        self.ref += math.copysign(stride, gap)
        return math.copysign(self.ref_speed, gap)

    def _speed_reference(self) -> float:
        if self.ramp is not None:
            start, end, t0, duration = self.ramp
            tau = (self.time - t0) / duration
            if tau >= 1.0:
                self.ramp = None
                self.speed_ref = end
            else:
                self.speed_ref = start + (end - start) * max(tau, 0.0)
        return self.speed_ref
