/**
 * Settings of a controller of another product line (RSA, RSAVW, SA, SM: spec/lines.json), by
 * the same names and units as MC's (settings.ts), with the same rules as `Motor.set`: a write
 * built from a read (the gains share one command) uses two agreeing reads; every written field
 * is read back once the EEPROM busy window has passed. A setting is there if the line has its
 * request (and, to write it, its command); the Python library's line-aware motor does the same.
 */
import type { Bus } from "./bus/client.js";
import { VerifyError } from "./bus/errors.js";
import type { Message } from "./codec.js";
import { askInLine, tellInLine } from "./discovery.js";
import { HOST_PROFILES } from "./generated/host.js";
import { lineMessageSpec } from "./lines.js";
import { SETTINGS, type SettingSpec, type SettingValue, setting, settingFromWire, settingToWire } from "./settings.js";

const has = (line: string, name: string | null): boolean => {
  if (name === null) return false;
  try {
    lineMessageSpec(line, name);
    return true;
  } catch {
    return false;
  }
};

/** The settings a line can read (its request exists and its answer holds the field). */
export function lineSettings(line: string): SettingSpec[] {
  return SETTINGS.filter((s) => {
    if (!has(line, s.request)) return false;
    const answer = lineMessageSpec(line, lineMessageSpec(line, s.request as string).answer as string);
    return answer.fields.some((f) => f.name === s.field);
  });
}

/** Whether the line has the command that writes this setting. */
export const lineWritable = (line: string, spec: SettingSpec): boolean =>
  spec.command !== null && has(line, spec.command) && lineSettings(line).includes(spec);

const fieldsOfLine = (message: Message): Record<string, number> => {
  const out: Record<string, number> = {};
  for (const [key, value] of Object.entries(message)) if (typeof value === "number" && key !== "id") out[key] = value;
  return out;
};

async function ask(bus: Bus, line: string, request: string, id: number): Promise<Record<string, number>> {
  const answer = await askInLine(bus, line, request, id);
  if (answer === null) {
    const error = new Error(
      `no answer to ${request} from ID ${id} at ${bus.baudRate} bps (${line} line) after ${bus.retries + 1} attempt(s)`,
    );
    error.name = "NoAnswerError";
    throw error;
  }
  return fieldsOfLine(answer);
}

/** Every setting the line can read, each request asked once. */
export async function readLineSettings(bus: Bus, line: string, id: number): Promise<Record<string, SettingValue>> {
  const answers = new Map<string, Record<string, number>>();
  const out: Record<string, SettingValue> = {};
  for (const spec of lineSettings(line)) {
    const request = spec.request as string;
    let fields = answers.get(request);
    if (fields === undefined) {
      fields = await ask(bus, line, request, id);
      answers.set(request, fields);
    }
    out[spec.name] = settingFromWire(spec, fields[spec.field] ?? Number.NaN);
  }
  return out;
}

/** Write a setting in its physical unit (or value name), then read it back (VerifyError if it did not take). */
export async function setLineSetting(
  bus: Bus,
  line: string,
  id: number,
  name: string,
  value: SettingValue,
): Promise<SettingValue> {
  const spec = setting(name);
  if (!lineWritable(line, spec))
    throw new RangeError(`${spec.name} cannot be written on a controller of the ${line} line`);
  const raw = settingToWire(spec, value);
  const command = lineMessageSpec(line, spec.command as string);
  let fields: Record<string, number> = { [spec.field]: raw };
  if (command.fields.length > 1) {
    const seen: string[] = []; // two agreeing reads: noise that keeps the checksum is never written back
    let agreed: Record<string, number> | null = null;
    for (let i = 0; i < 4 && agreed === null; i++) {
      const read = await ask(bus, line, spec.request as string, id);
      const key = JSON.stringify(read);
      if (seen.includes(key)) agreed = read;
      seen.push(key);
    }
    if (agreed === null)
      throw new Error(`ID ${id}: 4 reads of ${spec.answer} all differ: noise on the bus; nothing was written`);
    fields = Object.fromEntries(
      command.fields.map((f) => [f.name, f.name === spec.field ? raw : (agreed[f.name] ?? 0)]),
    );
  }
  await tellInLine(bus, line, spec.command as string, id, fields);
  const busyMs = HOST_PROFILES[line]?.busyWindowMs ?? 300; // the controller ignores frames while it writes EEPROM
  await new Promise((resolve) => setTimeout(resolve, busyMs));
  const back = await ask(bus, line, spec.request as string, id);
  for (const [field, wrote] of Object.entries(fields)) {
    if (back[field] !== wrote) {
      const which = SETTINGS.find((s) => s.command === spec.command && s.field === field) ?? spec;
      throw new VerifyError(
        which.name,
        settingFromWire(which, wrote),
        settingFromWire(which, back[field] ?? Number.NaN),
      );
    }
  }
  return settingFromWire(spec, raw);
}
