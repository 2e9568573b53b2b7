"""The ranges of `nurimc ros2`'s (and `record`'s) numeric options, also the ranges of the bridge's
ROS parameters of the same names (ros2/parameters.py): one place, imported by both without a cycle."""

from __future__ import annotations

from .common import Number

# Every number is checked when the options are read, before the extra, the port or DDS is touched.
RATE = Number("--rate", 0, 10_000, "readings/s")
SECONDS = Number("--seconds", 0.01, 1_000_000, "s")
COMMAND_TIMEOUT = Number("--command-timeout", 0, 3600, "s")
#: rad/s between the wire's 0.1 and 6553.3 RPM (rounded inwards to the digits shown)
MOVE_VELOCITY = Number("--move-velocity", 0.0105, 686.2, "rad/s")
WHEEL_RADIUS = Number("--wheel-radius", 0.001, 10, "m")
WHEEL_SEPARATION = Number("--wheel-separation", 0.001, 100, "m")
MAX_LINEAR = Number("--max-linear", 0.001, 100, "m/s")
MAX_ANGULAR = Number("--max-angular", 0.001, 100, "rad/s")
MAX_LINEAR_ACCEL = Number("--max-linear-accel", 0.001, 100, "m/s²")
MAX_ANGULAR_ACCEL = Number("--max-angular-accel", 0.001, 100, "rad/s²")
