// Step-response figures from a recorded step (pure): the page computes them for the live trace
// and for the runs table the same way the server does (rise 10-90 %, overshoot, final error),
// plus the settling time (last entry into the ±2 % band of the step). One definition with its
// cases in spec/vectors/step-figures.json, run by Python, the TS library and this page (e2e/unit).
export const SETTLE_BAND = 0.02;

/** times (s since the step), positions (°), start and target (°) -> figures; null when not enough data. */
export function stepFigures(times, positions, start, target) {
  const step = target - start;
  if (!times.length || times.length !== positions.length || step === 0) return null;
  const progress = positions.map((p) => (p - start) / step);
  const cross = (level) => {
    const i = progress.findIndex((p) => p >= level);
    return i < 0 ? null : times[i];
  };
  const t10 = cross(0.1);
  const t90 = cross(0.9);
  const final = positions[positions.length - 1];
  const finalError = target - final;
  let settledAt = null;
  for (let i = progress.length - 1; i >= 0; i--) {
    if (Math.abs(1 - progress[i]) > SETTLE_BAND) break;
    settledAt = times[i];
  }
  return {
    rise: t10 != null && t90 != null ? t90 - t10 : null,
    overshoot: Math.max(0, (Math.max(...progress) - 1) * 100),
    settling: settledAt,
    finalError,
    settled: Math.abs(finalError) <= SETTLE_BAND * Math.abs(step),
  };
}
