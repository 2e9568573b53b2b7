/**
 * Step-response figures: rise time (10 % to 90 %), overshoot, settling into ±2 % and final
 * error. One definition for every language, stated with its cases in
 * spec/vectors/step-figures.json (Python: nurimc.dashboard.stepresponse.analyse).
 */

/** The settling band and the "settled" rule, as a fraction of the step. */
export const SETTLE_BAND = 0.02;
export const RISE_FROM = 0.1;
export const RISE_TO = 0.9;

export interface StepFigures {
  /** seconds from 10 % to 90 % of the step; null if it never got there */
  rise: number | null;
  /** percent of the step beyond the target (0 if none) */
  overshoot: number;
  /** seconds: the first sample of the last run inside ±2 % that lasts to the end; null if the last sample is outside */
  settling: number | null;
  /** degrees, target - last position */
  finalError: number;
  /** the last sample is within 2 % of the step from the target */
  settled: boolean;
}

/** Figures of a step from `start` to `target` sampled as (times, positions); RangeError on unusable input. */
export function stepFigures(
  times: readonly number[],
  positions: readonly number[],
  start: number,
  target: number,
): StepFigures {
  if (times.length !== positions.length || times.length === 0)
    throw new RangeError("a step response needs as many times as positions, at least one");
  const step = target - start;
  if (step === 0) throw new RangeError("a step needs different start and target positions");
  const progress = positions.map((p) => (p - start) / step); // 0 at start, 1 at target, whatever the sign
  const firstTime = (level: number): number | null => {
    const i = progress.findIndex((x) => x >= level);
    return i < 0 ? null : (times[i] as number);
  };
  const t10 = firstTime(RISE_FROM);
  const t90 = firstTime(RISE_TO);
  let settling: number | null = null;
  for (let i = progress.length - 1; i >= 0; i--) {
    if (Math.abs(1 - (progress[i] as number)) > SETTLE_BAND) break;
    settling = times[i] as number;
  }
  const finalError = target - (positions[positions.length - 1] as number);
  return {
    rise: t10 !== null && t90 !== null ? t90 - t10 : null,
    overshoot: Math.max(0, (Math.max(...progress) - 1) * 100),
    settling,
    finalError,
    settled: Math.abs(finalError) <= SETTLE_BAND * Math.abs(step),
  };
}
