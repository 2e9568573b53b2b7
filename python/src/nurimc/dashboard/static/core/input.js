// Strict input: an empty or invalid field is an error, never a value (0 or NaN).
import { num, t } from "./i18n.js";

export class InputProblem extends Error {}
const NUMBER = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;
export const looksNumeric = (raw) => NUMBER.test(raw);

/**
 * The number in `input` (an <input>), or an InputProblem naming `label` and what is wrong.
 * Options: min, max, integer, above (strictly greater), nonzero.
 */
export function readNumber(
  input,
  label,
  { min = -Infinity, max = Infinity, integer = false, above = null, nonzero = false } = {},
) {
  const raw = String(input.value ?? "").trim();
  const fail = (key, params = {}) => {
    input.setAttribute?.("aria-invalid", "true");
    input.focus?.();
    throw new InputProblem(`${label}: ${t(key, { raw, ...params })}`);
  };
  if (input.validity?.badInput) fail("input.notNumber");
  if (raw === "") fail("input.empty");
  if (!NUMBER.test(raw)) fail("input.notNumberQuoted");
  const value = Number(raw);
  if (!Number.isFinite(value)) fail("input.notFinite");
  if (integer && !Number.isInteger(value)) fail("input.notWhole");
  if (above != null && !(value > above)) fail("input.above", { above });
  if (nonzero && value === 0) fail("input.nonzero");
  if (value < min || value > max) fail("input.range", { min: fmt(min), max: fmt(max) });
  input.removeAttribute?.("aria-invalid");
  return value;
}
const fmt = (v) => (Number.isInteger(v) ? String(v) : String(v));
export { num };
