// Pure helpers for the live series (no DOM): kept samples, windows, several motors on one axis, CSV.

/** Index of the first sample within `windowS` seconds before `now` (times ascending). */
export function windowStart(times, now, windowS) {
  let first = times.length;
  while (first > 0 && times[first - 1] >= now - windowS) first--;
  return first;
}

/** Drop samples older than `keepS` before `now` from every array of `series` (keyed like {t, ...}). */
export function trim(series, now, keepS) {
  let drop = 0;
  while (drop < series.t.length && series.t[drop] < now - keepS) drop++;
  if (drop) for (const key of Object.keys(series)) series[key].splice(0, drop);
  return drop;
}

/** Linear interpolation of (times, values) at time `x`; null outside the samples or next to a null. */
export function interpolate(times, values, x, from = 0) {
  let i = from;
  while (i < times.length && times[i] < x) i++;
  if (i < times.length && times[i] === x) return values[i];
  if (i === 0 || i >= times.length) return null;
  const a = values[i - 1];
  const b = values[i];
  if (a == null || b == null) return null;
  const t0 = times[i - 1];
  const t1 = times[i];
  return a + ((b - a) * (x - t0)) / (t1 - t0);
}

/**
 * Several series, each with its own sample times, on one time axis (what uPlot draws):
 * the union of the times, each series interpolated between its own samples at the others'
 * times. Series sampled one after another (motors read in turn) thus draw continuous lines
 * instead of isolated points between gaps. `tracks`: [{ t: [...], v: [...] }].
 * Returns [x, y1, y2, ...] with x relative to `now` when given.
 */
export function alignTracks(tracks, now = null) {
  const times = [...new Set(tracks.flatMap((track) => track.t))].sort((a, b) => a - b);
  const columns = tracks.map((track) => {
    const out = new Array(times.length);
    let j = 0;
    for (let i = 0; i < times.length; i++) {
      while (j < track.t.length && track.t[j] < times[i]) j++;
      if (j < track.t.length && track.t[j] === times[i]) out[i] = track.v[j];
      else if (j === 0 || j >= track.t.length) out[i] = null;
      else {
        const a = track.v[j - 1];
        const b = track.v[j];
        out[i] =
          a == null || b == null ? null : a + ((b - a) * (times[i] - track.t[j - 1])) / (track.t[j] - track.t[j - 1]);
      }
    }
    return out;
  });
  return [now == null ? times : times.map((t) => t - now), ...columns];
}

/** The value of one signal of a motor's kept series at index i (following error = target − position). */
export function signalValue(series, signal, i) {
  if (signal === "error") {
    const target = series.target[i];
    return target == null ? null : target - series.position[i];
  }
  return series[signal][i];
}

/** CSV text from a header and rows (numbers as they are, null as empty). */
export function csv(header, rows) {
  const cell = (v) => (v == null ? "" : typeof v === "string" && /[",\n]/.test(v) ? `"${v.replace(/"/g, '""')}"` : v);
  return `${[header, ...rows].map((row) => row.map(cell).join(",")).join("\n")}\n`;
}

/** The last element of an array, or null. */
export const lastOf = (array) => (array.length ? array[array.length - 1] : null);
