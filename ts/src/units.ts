/**
 * Physical units <-> wire integers, with the rule every language follows
 * (docs/protocol.md): a physical value becomes the nearest wire step, halves
 * rounded away from zero, computed in decimal so that binary floating noise
 * (180.005 stored as 180.00499999...) never shifts the result. Wire -> physical
 * is exact to the step's decimals (3 * 0.1 gives 0.3, not 0.30000000000000004).
 *
 * Units: position in degrees (0.01 deg; 0.1 deg in speed feedback, erratum 6),
 * speed in RPM (0.1 RPM), current in amperes (0.1 A), arrival time in seconds
 * (0.1 s), response time in microseconds (100 us), reduction ratio as n:1 (0.1).
 */
import { LIMITS } from "./generated/host.js";
import type { MessageName } from "./generated/messages.js";
import { SPECS } from "./generated/tables.js";
import type { FieldSpec } from "./schema.js";

/** A number's shortest decimal form as digits * 10^exponent (exact, like Python's Decimal(repr(x))). */
function decimalOf(value: number): { digits: bigint; exponent: number } {
  const match = /^(-?)(\d+)(?:\.(\d+))?(?:e([+-]?\d+))?$/.exec(String(value));
  if (match === null) throw new RangeError(`${value} is not a finite number`);
  const [, sign = "", whole = "", fraction = "", exp = "0"] = match;
  const digits = BigInt(sign + whole + fraction);
  return { digits, exponent: Number(exp) - fraction.length };
}

const pow10 = (n: number): bigint => 10n ** BigInt(n);

/** Physical value -> wire integer: the nearest step, halves away from zero (180.005 deg at 0.01 -> 18001). */
export function toWire(value: number, scale: number): number {
  if (!Number.isFinite(value)) throw new RangeError(`${value} is not a finite number`);
  if (!Number.isFinite(scale) || scale <= 0) throw new RangeError(`scale ${scale} must be a positive number`);
  const v = decimalOf(value);
  const s = decimalOf(scale);
  const shift = v.exponent - s.exponent;
  let num = shift >= 0 ? v.digits * pow10(shift) : v.digits;
  const den = shift >= 0 ? s.digits : s.digits * pow10(-shift);
  const negative = num < 0n;
  if (negative) num = -num;
  let steps = num / den;
  if (2n * (num % den) >= den) steps += 1n;
  return Number(negative ? -steps : steps);
}

/** 10^0..10^22, each exactly a double. */
const POW10 = [
  1, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
  1e21, 1e22,
];

/** The decimal form of each scale seen (a handful): fromWire runs for every field of every answer. */
const scaleDecimals = new Map<number, { digits: bigint; exponent: number; safeDigits: number }>();

/** Wire integer -> physical value, exact to the scale's decimals. */
export function fromWire(raw: number, scale: number): number {
  let s = scaleDecimals.get(scale);
  if (s === undefined) {
    const d = decimalOf(scale);
    s = { ...d, safeDigits: Number(d.digits) };
    if (scaleDecimals.size < 64) scaleDecimals.set(scale, s);
  }
  if (s.exponent >= 0 || !Number.isInteger(raw)) {
    return s.exponent >= 0 ? raw * scale : Number((raw * scale).toFixed(-s.exponent));
  }
  // exact while a safe integer (the BigInt product's digits), and 10^k is exact for k <= 22: IEEE
  // division rounds the exact quotient to the nearest double, as parsing "digits e-k" does
  const product = raw * s.safeDigits;
  if (product === 0) return 0; // not -0, as the BigInt product
  if (Number.isSafeInteger(product) && -s.exponent < POW10.length) return product / (POW10[-s.exponent] as number);
  return Number(`${BigInt(raw) * s.digits}e${s.exponent}`);
}

export const degreesToWire = (degrees: number, scale = 0.01): number => toWire(degrees, scale);
export const rpmToWire = (rpm: number): number => toWire(rpm, 0.1);
export const amperesToWire = (amperes: number): number => toWire(amperes, 0.1);
export const secondsToWire = (seconds: number): number => toWire(seconds, 0.1);
export const microsecondsToWire = (microseconds: number): number => toWire(microseconds, 100);
/** 12.5 (meaning 12.5:1) -> 125. */
export const ratioToWire = (ratio: number): number => toWire(ratio, 0.1);

/** `1..65533 (0.1..6553.3 rpm)`: the wire range and, where scaled, its physical range. */
export function describeRange(field: FieldSpec): string {
  let text = `${field.min}..${field.max}`;
  if (field.unit !== "" && field.scale !== 1) {
    text += ` (${fromWire(field.min, field.scale)}..${fromWire(field.max, field.scale)} ${field.unit})`;
  } else if (field.unit !== "" && field.unit !== "count") {
    text += ` ${field.unit}`;
  }
  const names = Object.entries(field.values);
  if (names.length > 0) text += ` (${names.map(([v, n]) => `${v} ${n}`).join(", ")})`;
  return text;
}

/** A physical value the protocol cannot carry: names the quantity, the value and what is allowed. */
export class UnitRangeError extends RangeError {
  override name = "UnitRangeError";
  constructor(
    /** e.g. "rpm", "ratio" */
    readonly quantity: string,
    readonly value: unknown,
    /** e.g. "-6553.3..-0.1 or 0.1..6553.3 rpm" */
    readonly allowed: string,
  ) {
    super(
      `${quantity} = ${typeof value === "string" ? JSON.stringify(value) : String(value)} is out of range; allowed: ${allowed}`,
    );
  }
}

/** A signed physical value as the protocol carries it: a direction flag (0 CCW = +, 1 CW = -) and a magnitude. */
export interface SignedWire {
  direction: 0 | 1;
  wire: number;
}

/**
 * The motion quantities, with the limits of spec/host.json (LIMITS) and the fields of
 * spec/protocol.json: the value is rounded to the nearest step first, then its wire
 * value is range-checked (655.334 deg is 65533, allowed; 655.335 deg is 65534, refused).
 */
function scaleOf(message: MessageName, name: string): number {
  const field = SPECS[message].fields.find((f) => f.name === name);
  if (field === undefined) throw new Error(`spec: ${message} has no field ${name}`);
  return field.scale;
}
function limits(scale: number, min: number, max: number) {
  return { scale, min: toWire(min, scale), max: toWire(max, scale) };
}
const POSITION = limits(scaleOf("position_speed", "position"), 0, LIMITS.positionDeg);
const SPEED = limits(scaleOf("accel_speed", "speed"), LIMITS.speedRpmMin, LIMITS.speedRpmMax);
const ARRIVAL = limits(scaleOf("accel_speed", "arrival_time"), LIMITS.arrivalSMin, LIMITS.arrivalSMax);

function finite(quantity: string, value: number, allowed: string): number {
  if (typeof value !== "number" || !Number.isFinite(value)) throw new UnitRangeError(quantity, value, allowed);
  return value;
}

/** Signed degrees (CCW +) -> direction and 0.01-degree magnitude of a position command (|degrees| <= 655.33). */
export function positionToWire(degrees: number): SignedWire {
  const allowed = `-${fromWire(POSITION.max, POSITION.scale)}..${fromWire(POSITION.max, POSITION.scale)} deg`;
  const wire = Math.abs(toWire(finite("degrees", degrees, allowed), POSITION.scale));
  if (wire > POSITION.max) throw new UnitRangeError("degrees", degrees, allowed);
  return { direction: degrees < 0 ? 1 : 0, wire };
}

/** Signed RPM (CCW +) -> direction and 0.1-RPM magnitude of a speed command (0.1..6553.3 either way; 0 is refused). */
export function speedToWire(rpm: number): SignedWire {
  const top = fromWire(SPEED.max, SPEED.scale);
  const low = fromWire(SPEED.min, SPEED.scale);
  const allowed = `-${top}..-${low} or ${low}..${top} rpm (speed 0 is invalid: release or hold to stop)`;
  const wire = Math.abs(toWire(finite("rpm", rpm, allowed), SPEED.scale));
  if (wire < SPEED.min || wire > SPEED.max) throw new UnitRangeError("rpm", rpm, allowed);
  return { direction: rpm < 0 ? 1 : 0, wire };
}

/** Seconds -> the 0.1-s arrival (or ramp) time of a motion command (0.1..25.5 s). */
export function arrivalToWire(seconds: number): number {
  const allowed = `${fromWire(ARRIVAL.min, ARRIVAL.scale)}..${fromWire(ARRIVAL.max, ARRIVAL.scale)} s`;
  const wire = toWire(finite("seconds", seconds, allowed), ARRIVAL.scale);
  if (wire < ARRIVAL.min || wire > ARRIVAL.max) throw new UnitRangeError("seconds", seconds, allowed);
  return wire;
}

/** A direction flag and a magnitude (as feedback reports them) -> the signed physical value (CW is negative). */
export function signedFromWire(direction: number, wire: number, scale: number): number {
  const magnitude = fromWire(wire, scale);
  return direction === 1 ? -magnitude : magnitude;
}
