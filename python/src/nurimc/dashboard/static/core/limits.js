// Every limit, rate and unit the page uses, from the generated spec (spec/*.json via
// `make generate`); e2e/unit/limits.test.mjs fails if a view types one of them again.
import { BAUD_RATES, HOST_STOP, HOST_TIMING, LIMITS, PROFILES, SETTINGS } from "../generated/spec.js";

export { BAUD_RATES, HOST_STOP, HOST_TIMING, LIMITS, PROFILES, SETTINGS };

/** Controller IDs 0..254 (255 is the broadcast address; document §4). Not in the generated spec.js yet: the one place it is typed. */
export const MAX_ID = 254;
/** The longest EEPROM busy window of any product (a settings write keeps a controller deaf this long). */
export const BUSY_WINDOW_MS = Math.max(...Object.values(PROFILES).map((p) => p.busyWindowMs));

/** Moves are given in the device's frame: a target beyond this is refused (±655.33°). */
export const MOVE_LIMIT = LIMITS.positionDeg;
/** The device reports positions up to the wrap (the counter wraps at 65536 counts = 655.36°). */
export const DEVICE_LIMIT = LIMITS.positionWrapDeg;
export const RPM_MIN = LIMITS.speedRpmMin;
export const RPM_MAX = LIMITS.speedRpmMax;
/** The rate a new page offers first (the controllers' most common setting in the field). */
export const DEFAULT_BAUD = BAUD_RATES.includes(115200) ? 115200 : BAUD_RATES[0];

/** A setting's range and unit by name ("position-kp" -> {min, max, unit, ...}), physical values. */
export function settingSpec(name) {
  const s = SETTINGS.find((entry) => entry.name === name);
  if (!s) throw new Error(`unknown setting ${name}`);
  return s;
}
