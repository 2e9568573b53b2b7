/**
 * Backup files in the CLI's format (`nurimc backup` / `nurimc restore`; python/src/nurimc/backup.py
 * and config.py): a JSON object with `format` ("nurimc-backup/1"), `protocol`, `time` and
 * `motors`, each motor `id`, `baudrate`, `product` and `settings` (physical units, as
 * `nurimc get` shows them). Read strictly: anything else is refused with one line naming the
 * file, the motor and the field, before anything is written.
 *
 * Restore (the Python rules): each motor is checked to be of the backup's product line first
 * (a file from another line writes nothing); settings written by one command are judged from
 * two agreeing reads and written together with the backup's values (never a value noise put
 * there); control is left as it is; every written field is read back. A journal (kept by the
 * caller: a file for the CLI, localStorage in the browser) marks each motor before its first
 * write and is cleared once every setting is confirmed: a restore that stopped (port gone,
 * tab closed) is found next time, and running it again writes only what still differs.
 */
import type { Bus } from "./bus/client.js";
import { VerifyError } from "./bus/errors.js";
import { fieldsOf, make } from "./codec.js";
import { BAUD_RATES, PRODUCTS, PROTOCOL } from "./generated/tables.js";
import { lineWritable, readLineSettings, setLineSetting } from "./linesettings.js";
import { Motor } from "./motor.js";
import { SETTINGS, type SettingSpec, type SettingValue, settingFromWire, settingToWire } from "./settings.js";
import { toWire } from "./units.js";

export const BACKUP_FORMAT = "nurimc-backup/1";
/** bytes; a backup of 255 motors is about 150 kB */
export const BACKUP_SIZE_LIMIT = 1 << 20;
const MAX_MOTORS = 255;
const TOP_KEYS = ["format", "protocol", "time", "motors"];
const MOTOR_KEYS = ["id", "baudrate", "product", "settings"];
/** Products a backup may name (spec/protocol.json), and the product line each speaks. */
const PRODUCT_NAMES: readonly string[] = Object.keys(PRODUCTS);
const LINE_OF_PRODUCT: Readonly<Record<string, string>> = {
  "blmc-h": "mc",
  sa: "rsa",
  "sm-cs": "sm",
  "sm-readme": "sm",
};
export const lineOfProduct = (product: string): string => LINE_OF_PRODUCT[product] ?? product;

export interface BackupMotor {
  id: number;
  baudrate?: number;
  product?: string;
  settings: Record<string, SettingValue>;
}

export interface BackupDocument {
  format: typeof BACKUP_FORMAT;
  protocol?: string;
  time?: string;
  motors: BackupMotor[];
}

/** A backup file or document that is not one we wrote; the message names file, motor and field. */
export class BackupError extends Error {
  override name = "BackupError";
}

const kind = (value: unknown): string => {
  if (typeof value === "string") return `the text ${JSON.stringify(value)}`;
  if (value === null) return "null";
  if (Array.isArray(value)) return "a list";
  if (typeof value === "object") return "an object";
  if (typeof value === "boolean") return "a boolean";
  return "a number";
};
const show = (value: unknown): string => (typeof value === "string" ? JSON.stringify(value) : String(value));
const isObject = (value: unknown): value is Record<string, unknown> =>
  typeof value === "object" && value !== null && !Array.isArray(value);

function only(mapping: Record<string, unknown>, known: readonly string[], where: string): void {
  const unknown = Object.keys(mapping).find((k) => !known.includes(k));
  if (unknown !== undefined)
    throw new BackupError(`${where}: unknown field ${JSON.stringify(unknown)}; a backup holds ${known.join(", ")}`);
}

/** One setting's value from a file: its name (a text) or a number on the wire's grid. */
function settingValue(spec: SettingSpec, value: unknown, where: string): SettingValue {
  const choices = Object.values(spec.values);
  if (typeof value === "string") {
    if (choices.length === 0) throw new BackupError(`${where}: ${show(value)} is text; give a number`);
    if (!choices.includes(value)) throw new BackupError(`${where}: ${show(value)} is not one of ${choices.join(", ")}`);
    return value;
  }
  if (typeof value !== "number" || !Number.isFinite(value))
    throw new BackupError(`${where}: ${kind(value)}; give a number`);
  let raw: number;
  try {
    raw = settingToWire(spec, value);
  } catch (error) {
    throw new BackupError(`${where}: ${(error as Error).message}`);
  }
  const onGrid = Math.abs((settingFromWire(spec, raw) as number) - value) <= 1e-9 * Math.max(1, Math.abs(value));
  if (spec.input === "quantize" && !onGrid) {
    const nearest = settingFromWire(spec, toWire(value, spec.scale));
    throw new BackupError(`${where}: ${value} is between the wire's steps; the nearest is ${nearest}`);
  }
  return choices.length > 0 ? settingFromWire(spec, raw) : value;
}

function checkMotor(entry: unknown, where: string): BackupMotor {
  if (!isObject(entry))
    throw new BackupError(`${where}: ${kind(entry)}, not a motor (an object with ${MOTOR_KEYS.join(", ")})`);
  const id = entry.id;
  if (typeof id === "string") throw new BackupError(`${where}: id ${show(id)} is text; give a number`);
  if (typeof id !== "number" || !Number.isInteger(id) || id < 0 || id > 254)
    throw new BackupError(`${where}: id ${show(id)} is not an ID; give 0..254`);
  where = `${where} (ID ${id})`;
  only(entry, MOTOR_KEYS, where);
  const motor: BackupMotor = { id, settings: {} };
  if ("baudrate" in entry) {
    const rate = entry.baudrate;
    if (typeof rate !== "number" || !BAUD_RATES.includes(rate))
      throw new BackupError(`${where}: baudrate ${show(rate)} bps is not one of ${BAUD_RATES.join(", ")}`);
    motor.baudrate = rate;
  }
  if ("product" in entry) {
    const product = entry.product;
    if (typeof product !== "string" || !PRODUCT_NAMES.includes(product))
      throw new BackupError(`${where}: product ${show(product)} is not one of ${PRODUCT_NAMES.join(", ")}`);
    motor.product = product;
  }
  const settings = entry.settings;
  if (!isObject(settings))
    throw new BackupError(`${where}: settings is ${kind(settings)}; give an object of setting: value`);
  for (const [name, value] of Object.entries(settings)) {
    const spec = SETTINGS.find((s) => s.name === name);
    const at = `${where}: settings.${JSON.stringify(name).slice(1, -1)}`;
    if (spec === undefined)
      throw new BackupError(`${at}: not a setting; settings: ${SETTINGS.map((s) => s.name).join(", ")}`);
    motor.settings[name] = settingValue(spec, value, at);
  }
  return motor;
}

/** The document as a clean backup, or BackupError naming `source`, the motor and the field. */
export function checkBackup(document: unknown, source = "backup"): BackupDocument {
  if (!isObject(document))
    throw new BackupError(`${source}: not a nurimc backup (the top level is ${kind(document)}, not an object)`);
  if (document.format !== BACKUP_FORMAT)
    throw new BackupError(
      `${source}: not a nurimc backup (format ${show(document.format)}, expected ${JSON.stringify(BACKUP_FORMAT)})`,
    );
  only(document, TOP_KEYS, source);
  for (const key of ["protocol", "time"])
    if (key in document && typeof document[key] !== "string")
      throw new BackupError(`${source}: ${key} is ${kind(document[key])}; give text`);
  const motors = document.motors;
  if (!Array.isArray(motors)) throw new BackupError(`${source}: motors is ${kind(motors)}; give a list of motors`);
  if (motors.length < 1 || motors.length > MAX_MOTORS)
    throw new BackupError(`${source}: motors holds ${motors.length} entries; give 1..${MAX_MOTORS}`);
  const clean: BackupMotor[] = [];
  const seen = new Set<number>();
  for (const [index, entry] of motors.entries()) {
    const motor = checkMotor(entry, `${source}: motors[${index}]`);
    if (seen.has(motor.id)) throw new BackupError(`${source}: motors[${index}]: ID ${motor.id} appears twice`);
    seen.add(motor.id);
    clean.push(motor);
  }
  const out: BackupDocument = { format: BACKUP_FORMAT, motors: clean };
  if (typeof document.protocol === "string") out.protocol = document.protocol;
  if (typeof document.time === "string") out.time = document.time;
  return out;
}

/** A backup file's text -> the checked document (BackupError naming `source` otherwise). */
export function parseBackup(text: string, source = "backup"): BackupDocument {
  if (new TextEncoder().encode(text).length > BACKUP_SIZE_LIMIT)
    throw new BackupError(`${source}: larger than ${BACKUP_SIZE_LIMIT} bytes; not a nurimc backup`);
  let document: unknown;
  try {
    document = JSON.parse(text);
  } catch (error) {
    const truncated = text.trim().length === 0 ? "it is empty" : (error as Error).message;
    throw new BackupError(`${source}: not a nurimc backup (not JSON: ${truncated}); choose a file written by backup`);
  }
  return checkBackup(document, source);
}

/** The text of a backup file, as the CLI writes it (two-space indent, a final newline). */
export const backupText = (document: BackupDocument): string =>
  `${JSON.stringify(checkBackup(document, "backup to save"), null, 2)}\n`;

const stamp = (date: Date): string => {
  const two = (n: number): string => String(n).padStart(2, "0");
  return `${date.getFullYear()}-${two(date.getMonth() + 1)}-${two(date.getDate())}T${two(date.getHours())}:${two(date.getMinutes())}:${two(date.getSeconds())}`;
};

/** A controller to back up or restore: where it answers and the line it speaks (discovery's Found). */
export interface Target {
  id: number;
  baudrate: number;
  line: string;
}

const refuseLine = (target: Target): never => {
  throw new BackupError(
    `ID ${target.id} speaks the ${target.line} line; backup and restore of that line need the Python console (nurimc backup / restore) in this version: nothing was read or written`,
  );
};

const isMc = (line: string): boolean => line === "mc" || line === "unknown";

/** Every setting of every motor (each in its line's table), as the CLI's document. Leaves the bus at its old rate. */
export async function makeBackup(bus: Bus, targets: readonly Target[], now = new Date()): Promise<BackupDocument> {
  for (const t of targets) if (!isMc(t.line) && !PRODUCT_NAMES.includes(t.line)) refuseLine(t);
  const original = bus.baudRate;
  const motors: BackupMotor[] = [];
  try {
    for (const t of targets) {
      if (bus.baudRate !== t.baudrate) await bus.setBaudRate(t.baudrate);
      const settings = isMc(t.line)
        ? await new Motor(bus, t.id).readSettings()
        : await readLineSettings(bus, t.line, t.id);
      motors.push({ id: t.id, baudrate: t.baudrate, product: isMc(t.line) ? "mc" : t.line, settings });
    }
  } finally {
    if (bus.baudRate !== original) await bus.setBaudRate(original);
  }
  return checkBackup({ format: BACKUP_FORMAT, protocol: PROTOCOL, time: stamp(now), motors });
}

/** Where the marks of restores under way are kept (the browser: localStorage; tests: a Map). */
export interface RestoreJournal {
  /** the backup whose restore to this ID did not finish, or null */
  pending(id: number): string | null;
  begin(ids: readonly number[], file: string): void;
  done(ids: readonly number[]): void;
}

/** A journal in a Storage (window.localStorage), one key per port name and ID. */
export class StorageJournal implements RestoreJournal {
  constructor(
    private readonly storage: Pick<Storage, "getItem" | "setItem" | "removeItem">,
    private readonly port: string,
  ) {}
  private key(id: number): string {
    return `nurimc.restore.${this.port}.id${id}`;
  }
  pending(id: number): string | null {
    try {
      const entry = JSON.parse(this.storage.getItem(this.key(id)) ?? "null") as { file?: unknown } | null;
      return typeof entry?.file === "string" ? entry.file : null;
    } catch {
      return null;
    }
  }
  begin(ids: readonly number[], file: string): void {
    for (const id of ids) this.storage.setItem(this.key(id), JSON.stringify({ file, since: Date.now() }));
  }
  done(ids: readonly number[]): void {
    for (const id of ids) this.storage.removeItem(this.key(id));
  }
}

/** One row of a restore's result: a setting written (verified) or one that already held. */
export interface RestoreRow {
  id: number;
  setting: string;
  before: SettingValue;
  after: SettingValue;
  verified: boolean;
}

/** Two reads that agree (at most `reads`): a write is never built from a value noise put there. */
async function confirmedFields(bus: Bus, id: number, request: string, reads = 4): Promise<Record<string, number>> {
  const seen: string[] = [];
  for (let i = 0; i < reads; i++) {
    const answer = fieldsOf(await bus.request(make(request, id, {})));
    const key = JSON.stringify(answer);
    if (seen.includes(key)) return answer;
    seen.push(key);
  }
  throw new BackupError(
    `ID ${id}: ${reads} reads all differ: noise on the bus gets past the checksum, so nothing was written; check termination, grounding and the cable, then try again`,
  );
}

/**
 * Write back every setting that differs from the backup (see the module comment). `targets`:
 * where each backed-up ID answers now and its line (discovery's finds); every ID of the backup
 * must be among them and of the backup's line, or nothing is written. Returns the rows changed.
 */
export async function restoreBackup(
  bus: Bus,
  document: BackupDocument,
  targets: readonly Target[],
  journal: RestoreJournal,
  file: string,
  onRow: (row: RestoreRow) => void = () => undefined,
): Promise<RestoreRow[]> {
  const doc = checkBackup(document, file);
  const plan: [BackupMotor, Target][] = [];
  for (const motor of doc.motors) {
    const target = targets.find((t) => t.id === motor.id);
    if (target === undefined)
      throw new BackupError(
        `${file}: the backup has ID ${motor.id}, which was not found on the bus; find it first (nothing was written)`,
      );
    const line = lineOfProduct(motor.product ?? "mc");
    if ((isMc(target.line) ? "mc" : target.line) !== line)
      throw new BackupError(
        `${file}: ID ${motor.id} in the backup is ${motor.product} (${line} line) but the controller speaks the ${target.line} line: a file from another product line; nothing was written`,
      );
    if (!isMc(line) && !PRODUCT_NAMES.includes(line)) refuseLine(target);
    plan.push([motor, target]);
  }
  const rows: RestoreRow[] = [];
  const original = bus.baudRate;
  try {
    for (const [motor, target] of plan) {
      if (bus.baudRate !== target.baudrate) await bus.setBaudRate(target.baudrate);
      journal.begin([motor.id], file);
      rows.push(
        ...(isMc(target.line)
          ? await restoreMotor(bus, motor, onRow)
          : await restoreLineMotor(bus, target.line, motor, onRow)),
      );
      journal.done([motor.id]);
    }
  } finally {
    if (bus.baudRate !== original) await bus.setBaudRate(original).catch(() => undefined);
  }
  return rows;
}

async function restoreMotor(bus: Bus, motor: BackupMotor, onRow: (row: RestoreRow) => void): Promise<RestoreRow[]> {
  const groups = new Map<string, SettingSpec[]>(); // command -> the settings it writes
  for (const name of Object.keys(motor.settings)) {
    const spec = SETTINGS.find((s) => s.name === name) as SettingSpec;
    if (spec.command === null || spec.name === "control") continue; // read-only; control is left as it is (safety)
    groups.set(spec.command, [...(groups.get(spec.command) ?? []), spec]);
  }
  const rows: RestoreRow[] = [];
  for (const [command, group] of groups) {
    const first = group[0] as SettingSpec;
    const now = await confirmedFields(bus, motor.id, first.request as string);
    const wanted = Object.fromEntries(
      group.map((s) => [s.field, settingToWire(s, motor.settings[s.name] as SettingValue)]),
    );
    const differing = group.filter((s) => now[s.field] !== wanted[s.field]);
    if (differing.length === 0) continue;
    const fields = { ...now, ...wanted }; // a field the backup lacks keeps its confirmed value
    await bus.send(make(command, motor.id, fields));
    if (first.name === "response-time") bus.responseTimesUs.delete(motor.id);
    const back = fieldsOf(await bus.request(make(first.request as string, motor.id, {})));
    for (const s of group) {
      if (back[s.field] !== wanted[s.field])
        throw new VerifyError(
          s.name,
          settingFromWire(s, wanted[s.field] as number),
          settingFromWire(s, back[s.field] ?? Number.NaN),
        );
    }
    for (const s of differing) {
      const row = {
        id: motor.id,
        setting: s.name,
        before: settingFromWire(s, now[s.field] as number),
        after: settingFromWire(s, wanted[s.field] as number),
        verified: true,
      };
      rows.push(row);
      onRow(row);
    }
  }
  return rows;
}

/** Another line's motor: each setting its line can write that differs, written and read back (setLineSetting). */
async function restoreLineMotor(
  bus: Bus,
  line: string,
  motor: BackupMotor,
  onRow: (row: RestoreRow) => void,
): Promise<RestoreRow[]> {
  const now = await readLineSettings(bus, line, motor.id);
  const rows: RestoreRow[] = [];
  for (const [name, wanted] of Object.entries(motor.settings)) {
    const spec = SETTINGS.find((s) => s.name === name) as SettingSpec;
    if (spec.name === "control" || !lineWritable(line, spec)) continue; // control is left as it is; a setting the line lacks
    const before = now[name] as SettingValue;
    if (before === settingFromWire(spec, settingToWire(spec, wanted))) continue;
    const after = await setLineSetting(bus, line, motor.id, name, wanted);
    const row = { id: motor.id, setting: name, before, after, verified: true };
    rows.push(row);
    onRow(row);
  }
  return rows;
}
