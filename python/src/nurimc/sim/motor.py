"""The motor as a simple rigid body: inertia, viscous and Coulomb friction, a torque (current) limit.

Everything is expressed at the output shaft in degrees and seconds, so the gearbox only
scales how much acceleration one ampere buys (torque x ratio, reflected inertia / ratio).
"""

from __future__ import annotations

from dataclasses import dataclass

# Output-shaft acceleration per ampere at ratio 1:1 (motor plus a light load), deg/s^2/A.
ACCEL_PER_AMP = 10_000.0
# Viscous friction: the speed decays with this rate (1/s) when the motor coasts.
VISCOUS = 2.0
# Coulomb (dry) friction as a deceleration, deg/s^2; it also holds a stopped motor still.
COULOMB = 300.0


@dataclass
class MotorState:
    angle: float = 0.0  # deg, output shaft, unwrapped
    speed: float = 0.0  # deg/s
    current: float = 0.0  # A, signed, what the drive applied in the last step
    accel: float = 0.0  # deg/s^2 in the last step


def step_motor(m: MotorState, current: float, accel_per_amp: float, dt: float) -> None:
    """Advance one step (semi-implicit Euler: stable for stiff friction at the step we use)."""
    drive = current * accel_per_amp
    speed = m.speed
    if speed == 0.0 and abs(drive) <= COULOMB:
        m.accel = 0.0  # static friction holds
        m.current = current
        return
    direction = 1.0 if speed > 0.0 or (speed == 0.0 and drive > 0.0) else -1.0
    accel = drive - VISCOUS * speed - COULOMB * direction
    new_speed = speed + accel * dt
    if speed != 0.0 and (new_speed > 0.0) != (speed > 0.0) and abs(drive) <= COULOMB:
        new_speed = 0.0  # friction stops the motor; it does not reverse it
    m.accel = (new_speed - speed) / dt
    m.speed = new_speed
    m.angle += new_speed * dt
    m.current = current
