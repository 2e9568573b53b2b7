"""Units: the library speaks degrees, RPM and amperes; ROS (REP 103) speaks radians and rad/s.

Effort is the motor current in amperes, as the controller reports it (a magnitude); the
controllers give no torque constant, so no newton-metres are claimed.
"""

from __future__ import annotations

import math

RAD_PER_DEG = math.pi / 180.0
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)


def deg_to_rad(degrees: float) -> float:
    return degrees * RAD_PER_DEG


def rad_to_deg(radians: float) -> float:
    return radians / RAD_PER_DEG


def rpm_to_rad_s(rpm: float) -> float:
    return rpm / RPM_PER_RAD_S


def rad_s_to_rpm(rad_s: float) -> float:
    return rad_s * RPM_PER_RAD_S


def stamp(ns: int) -> tuple[int, int]:
    """Nanoseconds since the epoch -> (sec, nanosec) of builtin_interfaces/Time."""
    return ns // 1_000_000_000, ns % 1_000_000_000
