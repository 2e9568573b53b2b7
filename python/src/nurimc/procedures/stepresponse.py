"""Step-response figures: rise time (10 % to 90 %), overshoot, settling into ±2 %, final error,
and for the tuner the current peak and oscillation.

Pure functions over recorded samples (no I/O): the console's step-response view and the tuner
(nurimc.procedures.tuning) measure with the same rules. One definition for every language:
spec/vectors/step-figures.json states it and holds cases that tell 90 % from 80 %, 10 % from 20 %
and a 2 % band from a 5 % one; `analyse` here, the TypeScript library (ts/src/stepfigures.ts) and
the console page (core/stepfigures.js) all run them. `response_figures` adds what a tuner needs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

#: the settling band and the "settled" rule, as a fraction of the step (a tuner may widen the band
#: to a reading's resolution or noise: response_figures' min_band)
SETTLE_BAND = 0.02
RISE_FROM, RISE_TO = 0.1, 0.9


@dataclass(frozen=True, slots=True)
class StepFigures:
    rise_time: float | None  # seconds from 10 % to 90 % of the step; None if it never got there
    overshoot: float  # percent of the step beyond the target (0 if none)
    settled: bool  # the last sample is within 2 % of the step from the target
    final_error: float  # degrees, target - last position
    settling_time: float | None = None  # first sample of the last run inside ±2 % that lasts to the end


def _progress(times: Sequence[float], values: Sequence[float], start: float, target: float) -> list[float]:
    if len(times) != len(values) or not times:
        raise ValueError("a step response needs as many times as positions, at least one")
    step = target - start
    if step == 0:
        raise ValueError("a step needs different start and target positions")
    return [(p - start) / step for p in values]  # 0 at start, 1 at target, whatever the sign


def _first_time(times: Sequence[float], progress: Sequence[float], level: float) -> float | None:
    return next((t for t, x in zip(times, progress, strict=True) if x >= level), None)


def analyse(times: Sequence[float], positions: Sequence[float], start: float, target: float) -> StepFigures:
    """Figures of a step from `start` to `target` sampled as (times, positions)."""
    progress = _progress(times, positions, start, target)
    step = target - start
    t10, t90 = _first_time(times, progress, RISE_FROM), _first_time(times, progress, RISE_TO)
    rise = t90 - t10 if t10 is not None and t90 is not None else None
    overshoot = max(0.0, (max(progress) - 1.0) * 100.0)
    final_error = target - positions[-1]
    settling: float | None = None
    for t, x in zip(reversed(times), reversed(progress), strict=True):
        if abs(1.0 - x) > SETTLE_BAND:
            break
        settling = t
    return StepFigures(
        rise, round(overshoot, 2), abs(final_error) <= SETTLE_BAND * abs(step), round(final_error, 3), settling
    )


@dataclass(frozen=True, slots=True)
class ResponseFigures:
    """What a tuner judges a response by (times in seconds from the step's start)."""

    rise_time: float | None  # 10 % to 90 % of the step; None if it never got to 90 %
    overshoot: float  # percent of the step beyond the target (0 if none)
    settling_time: float | None  # when it last entered the band and stayed; None if it ends outside
    final_error: float  # target - last value (the values' unit)
    current_peak: float  # A, the largest current read (0 if none were given)
    oscillations: int  # times it crossed the target from one side of the band to the other

    @property
    def settled(self) -> bool:
        return self.settling_time is not None

    def as_dict(self) -> dict[str, float | int | None]:
        return {
            "rise_time": self.rise_time,
            "overshoot": self.overshoot,
            "settling_time": self.settling_time,
            "final_error": self.final_error,
            "current_peak": self.current_peak,
            "oscillations": self.oscillations,
        }


def response_figures(
    times: Sequence[float],
    values: Sequence[float],
    start: float,
    target: float,
    currents: Sequence[float] = (),
    min_band: float = 0.0,
) -> ResponseFigures:
    """Figures of a step from `start` to `target` sampled as (times, values), times from the step's
    start. The settling band is 2 % of the step or `min_band` (a reading's resolution or noise)."""
    progress = _progress(times, values, start, target)
    step = abs(target - start)
    band = max(SETTLE_BAND, min_band / step)
    t10, t90 = _first_time(times, progress, RISE_FROM), _first_time(times, progress, RISE_TO)
    rise = t90 - t10 if t10 is not None and t90 is not None else None
    overshoot = max(0.0, (max(progress) - 1.0) * 100.0)
    settling: float | None = None
    for t, x in zip(times, progress, strict=True):
        if abs(x - 1.0) > band:
            settling = None
        elif settling is None:
            settling = t
    side = 0
    crossings = 0
    for x in progress:
        now = 1 if x > 1.0 + band else -1 if x < 1.0 - band else 0
        if now and side and now != side:
            crossings += 1
        if now:
            side = now
    return ResponseFigures(
        None if rise is None else round(rise, 4),
        round(overshoot, 2),
        None if settling is None else round(settling, 4),
        round(target - values[-1], 3),
        max((abs(c) for c in currents), default=0.0),
        crossings,
    )


__all__ = ["RISE_FROM", "RISE_TO", "SETTLE_BAND", "ResponseFigures", "StepFigures", "analyse", "response_figures"]
