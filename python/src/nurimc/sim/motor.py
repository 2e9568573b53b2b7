"""The motor as a simple rigid body: inertia, viscous and Coulomb friction, a torque (current) limit.

Everything is expressed at the output shaft in degrees and seconds. The friction and the
inertia belong to the motor (before the gearbox), so a gear ratio n:1 divides both the
acceleration one ampere buys and the Coulomb friction by n: seen from the motor shaft, a
geared motor behaves exactly like the bare motor, and the current it needs to start
(COULOMB / ACCEL_PER_AMP = 0.03 A) does not depend on the ratio. (Dividing only the
acceleration left geared motors stuck: 5 A could not start a 167:1 motor.)
"""

from __future__ import annotations

from dataclasses import dataclass

# Acceleration per ampere of the bare motor (a light load included), deg/s^2/A at the motor.
ACCEL_PER_AMP = 10_000.0
# Viscous friction: the speed decays at this rate (1/s) when the motor coasts. The same at
# either end of the gearbox (a rate). Light enough that 1 A holds the rated 3000 RPM.
VISCOUS = 0.5
# Coulomb (dry) friction at the motor, as a deceleration in deg/s^2; it also holds a stopped motor.
COULOMB = 300.0


@dataclass
class ShaftState:
    """The simulated motor shaft's physical state (not the library's nurimc.procedures.motor.MotorState reading)."""

    angle: float = 0.0  # deg, output shaft, unwrapped
    speed: float = 0.0  # deg/s
    current: float = 0.0  # A, signed, what the drive applied in the last step
    accel: float = 0.0  # deg/s^2 in the last step


def step_motor(
    m: ShaftState, current: float, accel_per_amp: float, coulomb: float, dt: float, viscous: float = VISCOUS
) -> None:
    """Advance one step (semi-implicit Euler: stable for stiff friction at the step we use).

    `accel_per_amp` and `coulomb` are at the output shaft (the motor's values / ratio);
    `viscous` is the coasting decay rate (1/s; a plant's inertia and viscous keys change it).
    """
    drive = current * accel_per_amp
    speed = m.speed
    m.current = current
    if speed == 0.0 and abs(drive) <= coulomb:
        m.accel = 0.0  # static friction holds
        return
    direction = 1.0 if speed > 0.0 or (speed == 0.0 and drive > 0.0) else -1.0
    accel = drive - viscous * speed - coulomb * direction
    new_speed = speed + accel * dt
    if speed != 0.0 and (new_speed > 0.0) != (speed > 0.0) and abs(drive) <= coulomb:
        new_speed = 0.0  # friction stops the motor; it does not reverse it
    m.accel = (new_speed - speed) / dt
    m.speed = new_speed
    m.angle += new_speed * dt
