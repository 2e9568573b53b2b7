"""Host-side multi-turn tracking that says when it cannot know.

The device reports position as a magnitude 0..655.35 deg with a direction flag (CCW = +,
CW = -); the magnitude wraps every 655.36 deg (65536 counts of 0.01 deg), so a reading d
only says the shaft is at d + k * 655.36 for some whole k. Between two readings the tracker
chooses k from what the motor can have done in the time between them:

- each reading carries the speed (signed from speed feedback's direction byte; position
  feedback carries only its magnitude, and its sign is taken from the position trend);
- from the speeds at both ends, the time between the readings and a bound on the acceleration
  (`max_accel`) and on the speed (`max_speed`), the tracker works out the least and the most
  the shaft can have turned, widened by what the timestamps and the wire's steps can be off
  (`timing`, 0.1 RPM, 0.01 deg);
- a motor seen at rest twice with no command sent to it since (the caller passes the count of
  commands sent to its ID: the bus is single-master, every frame goes through it) is still at
  rest, however long the gap: its step is the few counts of the shortest way;
- exactly one k inside that range: the step is known. None or several: the step is a guess
  (the one nearest the average speed times the time), and the position is marked
  **uncertain** from then on, until `reset()` (the continuous position is off by an unknown
  number of 655.36 deg turns; the device position itself stays right).

Without a time or a speed (old callers), the step is the shortest way round, as before. At
the defaults (100,000 deg/s^2, 36,000 deg/s) a turning motor read at least every 0.1 s is
tracked at any speed up to the rated 3,000 RPM; longer gaps are marked uncertain (what the
motor did in them cannot be told from the readings: docs/library.md, Sign and multi-turn
tracking), except for a motor at rest with no command sent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..protocol.host import LIMITS

WRAP_DEGREES = LIMITS["position_wrap_deg"]  # the device's position wraps here (spec/host.json)
#: The fastest change of speed assumed possible, deg/s^2 (0 to 3,000 RPM in 0.18 s).
DEFAULT_MAX_ACCEL = 100_000.0
#: The fastest speed assumed possible, deg/s (6,000 RPM, twice the MC's rated speed).
DEFAULT_MAX_SPEED = 36_000.0
#: How far a reading's timestamp may be from when the device sampled it, relative to the
#: previous reading's, seconds.
DEFAULT_TIMING = 0.003
SPEED_STEP = 0.6  # deg/s: the wire's 0.1 RPM
POSITION_STEP = 0.01  # deg: the wire's position step
#: Below this speed (deg/s) a reading's speed sign does not matter.
STILL = 1.0


def signed_degrees(direction: int, magnitude_deg: float) -> float:
    return -magnitude_deg if direction == 1 else magnitude_deg


def _most(a: float, b: float, dt: float, accel: float, top: float) -> float:
    """The most a shaft can turn in dt going from speed a to speed b (deg/s, signed) with
    |acceleration| <= accel and speed <= top: up as fast as possible, then down to b."""
    peak = (accel * dt + a + b) / 2
    if peak <= top:
        return ((peak - a) * (peak + a) + (peak - b) * (peak + b)) / (2 * accel)
    up, down = (top - a) / accel, (top - b) / accel
    return (top + a) / 2 * up + top * (dt - up - down) + (top + b) / 2 * down


def travel_range(a: float, b: float, dt: float, accel: float, top: float) -> tuple[float, float] | None:
    """The least and the most a shaft turns (deg) in dt from speed a to speed b; None if the
    change of speed needs more than `accel`."""
    if abs(b - a) > accel * dt:
        return None
    top = max(top, abs(a), abs(b))
    return -_most(-a, -b, dt, accel, top), _most(a, b, dt, accel, top)


@dataclass(frozen=True, slots=True)
class TurnStep:
    """What one reading did to the tracker."""

    position: float  # continuous degrees
    uncertain: bool  # the continuous position may be off by whole 655.36 deg turns
    speed: float | None  # signed deg/s at this reading if the tracker could tell the sign, else None


class TurnTracker:
    """Unwraps the device's position reading by reading (see the module's documentation)."""

    def __init__(
        self,
        max_accel: float = DEFAULT_MAX_ACCEL,
        max_speed: float = DEFAULT_MAX_SPEED,
        timing: float = DEFAULT_TIMING,
    ) -> None:
        self.max_accel = max_accel
        self.max_speed = max_speed
        self.timing = timing
        self.reset()

    def reset(self) -> None:
        """Forget the history: the next reading starts the continuous position afresh."""
        self._last: float | None = None
        self._at: float | None = None
        self._speeds: tuple[float, ...] = ()  # the last reading's possible signed speeds
        self.position = 0.0  # continuous degrees
        self.uncertain = False  # sticky until reset(): a step was a guess
        self.guesses = 0  # how many steps were guesses since reset()
        self.sign = 0  # the speed's sign as last known: +1 CCW, -1 CW, 0 unknown
        self._commands: int | None = None  # commands sent to the motor as of the last reading
        self._resting = False  # the last two readings at rest, no command between them
        self._still = False  # the last reading at rest

    def knows_sign(self) -> bool:
        """Whether the last reading's speed sign is known (or it was at rest)."""
        return len(self._speeds) == 1

    def update(
        self,
        device_degrees: float,
        speed: float | None = None,
        at: float | None = None,
        signed: bool = False,
        commands: int | None = None,
    ) -> float:
        """The continuous position after a reading (see `step` for the arguments)."""
        return self.step(device_degrees, speed, at, signed, commands).position

    def step(
        self,
        device_degrees: float,
        speed: float | None = None,
        at: float | None = None,
        signed: bool = False,
        commands: int | None = None,
    ) -> TurnStep:
        """Take a reading: the device's signed position (deg), its speed (deg/s; a magnitude
        unless `signed`), when it was read (s, any monotonic clock) and how many commands had
        been sent to the motor by then (None: not known)."""
        return TurnStep(*self.advance(device_degrees, speed, at, signed, commands))

    def advance(
        self,
        device_degrees: float,
        speed: float | None = None,
        at: float | None = None,
        signed: bool = False,
        commands: int | None = None,
    ) -> tuple[float, bool, float | None]:
        """`step` as a plain tuple (position, uncertain, speed): what a reading's conversion
        (Motor.state_from, on every reading) takes, without a TurnStep to build."""
        if speed is None:  # _options, inline
            speeds: tuple[float, ...] = ()
            still = False
        elif signed or -STILL < speed < STILL:
            speeds = (speed,)
            still = -STILL < speed < STILL
        else:
            speeds = (abs(speed), -abs(speed))
            still = False
        quiet = commands is not None and commands == self._commands
        last = self._last
        if last is None:
            self.position = device_degrees
            known = None
        else:
            shortest = (device_degrees - last + WRAP_DEGREES / 2) % WRAP_DEGREES - WRAP_DEGREES / 2
            gap = None if speed is None or at is None or self._at is None or not self._speeds else at - self._at
            rested = self._resting and quiet and still  # at rest, nothing told it to move: it did not
            if gap is None or rested:
                delta, known = shortest, None
            else:
                delta, known, sure = self._choose(shortest, speeds, gap)
                if not sure:
                    self.uncertain = True
                    self.guesses += 1
            self.position += delta
            if known is not None:
                speeds = (known,)
            elif len(speeds) > 1 and abs(delta) > POSITION_STEP:  # the trend gives the sign
                trend = math.copysign(1.0, delta)
                speeds = tuple(s for s in speeds if math.copysign(1.0, s) == trend) or speeds
        self._last, self._at = device_degrees, at
        self._speeds = speeds
        self._resting = still and self._still and quiet
        self._still, self._commands = still, commands
        position = self.position = round(self.position, 6)
        if len(speeds) == 1:
            one = speeds[0]
            self.sign = (1 if one > 0 else -1) if abs(one) >= STILL else 0
            return position, self.uncertain, one
        return position, self.uncertain, None

    def _choose(self, shortest: float, speeds: tuple[float, ...], dt: float) -> tuple[float, float | None, bool]:
        """(step, this reading's signed speed if decided, whether the step is certain)."""
        if dt <= 0:
            return shortest, None, abs(shortest) < WRAP_DEGREES / 4
        ranges: list[tuple[float, float, float, float]] = []  # lo, hi, end speed, estimate
        for a in self._speeds:
            for b in speeds:
                span = travel_range(a, b, dt, self.max_accel, self.max_speed)
                if span is None:
                    continue
                margin = self.timing * max(abs(a), abs(b)) + SPEED_STEP * dt + POSITION_STEP
                ranges.append((span[0] - margin, span[1] + margin, b, (a + b) / 2 * dt))
        if not ranges:  # the speeds changed faster than max_accel allows: the bound is wrong, guess
            a, b = self._speeds[0], speeds[0]
            k = round(((a + b) / 2 * dt - shortest) / WRAP_DEGREES)
            return shortest + k * WRAP_DEGREES, None, False
        found: dict[int, set[float]] = {}
        for lo, hi, b, _ in ranges:
            for k in range(math.ceil((lo - shortest) / WRAP_DEGREES), math.floor((hi - shortest) / WRAP_DEGREES) + 1):
                found.setdefault(k, set()).add(b)
        if len(found) == 1:
            ((k, ends),) = found.items()
            end = next(iter(ends)) if len(ends) == 1 else None
            return shortest + k * WRAP_DEGREES, end, True
        # a guess: the whole turn nearest the estimate of the hypothesis that keeps the sign
        keep = [r for r in ranges if self.sign == 0 or r[2] * self.sign >= 0] or ranges
        estimate = keep[0][3]
        k = round((estimate - shortest) / WRAP_DEGREES)
        return shortest + k * WRAP_DEGREES, None, False


def _options(speed: float | None, signed: bool) -> tuple[float, ...]:
    """The signed speeds a reading's speed can be (deg/s)."""
    if speed is None:
        return ()
    if signed or abs(speed) < STILL:
        return (speed,)
    return (abs(speed), -abs(speed))
