"""Step-response figures for tuning: rise time (10 % to 90 %), overshoot, settling into ±2 %
and final error of a recorded move.

One definition for every language: spec/vectors/step-figures.json states it and holds cases
that tell 90 % from 80 %, 10 % from 20 % and a 2 % band from a 5 % one; this module, the
TypeScript library (ts/src/stepfigures.ts) and the console page (core/stepfigures.js) all run them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

#: the settling band and the "settled" rule, as a fraction of the step
SETTLE_BAND = 0.02
RISE_FROM, RISE_TO = 0.1, 0.9


@dataclass(frozen=True, slots=True)
class StepFigures:
    rise_time: float | None  # seconds from 10 % to 90 % of the step; None if it never got there
    overshoot: float  # percent of the step beyond the target (0 if none)
    settled: bool  # the last sample is within 2 % of the step from the target
    final_error: float  # degrees, target - last position
    settling_time: float | None = None  # first sample of the last run inside ±2 % that lasts to the end


def analyse(times: Sequence[float], positions: Sequence[float], start: float, target: float) -> StepFigures:
    """Figures of a step from `start` to `target` sampled as (times, positions)."""
    if len(times) != len(positions) or not times:
        raise ValueError("a step response needs as many times as positions, at least one")
    step = target - start
    if step == 0:
        raise ValueError("a step needs different start and target positions")
    progress = [(p - start) / step for p in positions]  # 0 at start, 1 at target, whatever the sign

    def first_time(level: float) -> float | None:
        return next((t for t, x in zip(times, progress, strict=True) if x >= level), None)

    t10, t90 = first_time(RISE_FROM), first_time(RISE_TO)
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
