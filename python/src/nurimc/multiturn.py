"""Host-side multi-turn tracking.

The device reports position as a magnitude 0..655.35 deg with a direction flag (CCW = +,
CW = -) and its counter wraps every 655.36 deg (65536 counts of 0.01 deg). The tracker
unwraps successive readings: each step is taken as the shortest way round the 655.36 deg
circle, so the continuous position is right as long as the motor turns less than half a
wrap (327.68 deg) between two readings — at 100 RPM, poll at least every 0.5 s.
"""

from __future__ import annotations

from .protocol.host import LIMITS

WRAP_DEGREES = LIMITS["position_wrap_deg"]  # the device's position wraps here (spec/host.json)


def signed_degrees(direction: int, magnitude_deg: float) -> float:
    return -magnitude_deg if direction == 1 else magnitude_deg


class TurnTracker:
    def __init__(self) -> None:
        self._last: float | None = None
        self.position = 0.0  # continuous degrees

    def update(self, device_degrees: float) -> float:
        if self._last is None:
            self.position = device_degrees
        else:
            step = (device_degrees - self._last + WRAP_DEGREES / 2) % WRAP_DEGREES - WRAP_DEGREES / 2
            self.position += step
        self._last = device_degrees
        self.position = round(self.position, 6)
        return self.position

    def reset(self) -> None:
        self._last = None
        self.position = 0.0
