/**
 * Every controller setting by name, in physical units: the table of spec/settings.json
 * (generated into generated/settings.ts), the same names and input rules as the Python
 * library (`nurimc.procedures.settings`) and the CLI: "position-kp", "ratio", "control", ...
 */
import { SETTINGS, type SettingSpec } from "./generated/settings.js";
import { fromWire, toWire, UnitRangeError } from "./units.js";

export type { SettingSpec } from "./generated/settings.js";
export { SETTINGS } from "./generated/settings.js";

/** A physical value of a setting: a number, or a value name ("on", "relative", "cw"). */
export type SettingValue = number | string;

const BY_NAME: ReadonlyMap<string, SettingSpec> = new Map(SETTINGS.map((s) => [s.name, s]));

/** The setting called `name` ("position-kp" or "position_kp"); a RangeError listing the names otherwise. */
export function setting(name: string): SettingSpec {
  const found = BY_NAME.get(name.trim().toLowerCase().replaceAll("_", "-"));
  if (found === undefined)
    throw new RangeError(
      `unknown setting ${JSON.stringify(name)}; settings: ${SETTINGS.map((s) => s.name).join(", ")}`,
    );
  return found;
}

/** "0.1..25.4 A", "1..254", "on or off". */
export function describeSetting(spec: SettingSpec): string {
  const names = Object.values(spec.values);
  if (spec.input === "choice") return names.join(" or ");
  return `${spec.physicalMin}..${spec.physicalMax}${spec.unit === "" ? "" : ` ${spec.unit}`}`;
}

/**
 * A physical value -> the wire integer, by the setting's input rule (spec/settings.json):
 * `integer` takes a whole number (a fraction is refused), `quantize` the nearest wire step
 * (halves away from zero, on the value's decimal form), `choice` a value name or its wire
 * integer. The wire value must be in the field's range. UnitRangeError otherwise.
 */
export function settingToWire(spec: SettingSpec, value: SettingValue): number {
  const refuse = (): never => {
    throw new UnitRangeError(spec.name, value, describeSetting(spec));
  };
  if (typeof value === "string") {
    const wanted = value.trim().toLowerCase();
    const entry = Object.entries(spec.values).find(([, n]) => n === wanted);
    return entry === undefined ? refuse() : Number(entry[0]);
  }
  if (typeof value !== "number" || !Number.isFinite(value)) return refuse();
  let raw: number;
  if (spec.input === "quantize") raw = toWire(value, spec.scale);
  else if (Number.isInteger(value)) raw = value;
  else return refuse();
  return raw >= spec.min && raw <= spec.max ? raw : refuse();
}

/** A wire integer -> the physical value: its value name if it has one, else the number in the setting's unit. */
export function settingFromWire(spec: SettingSpec, raw: number): SettingValue {
  return spec.values[raw] ?? fromWire(raw, spec.scale);
}
