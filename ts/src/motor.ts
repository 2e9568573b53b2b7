/**
 * A motor handle: one controller ID on a Bus, in physical units (degrees, RPM,
 * amperes, seconds, microseconds, n:1). Settings writes are verified by reading back.
 *
 * Position on the wire is a magnitude (0..655.33 deg) with a direction flag; this
 * handle passes both through as they are and keeps no multi-turn count.
 */
import type { Bus } from "./bus/client.js";
import { VerifyError } from "./bus/errors.js";
import { make, messageSpec } from "./codec.js";
import { fromWire, toWire } from "./units.js";

export type Direction = "ccw" | "cw";

export interface MotorState {
  /** degrees, 0..655.33, the magnitude of the position */
  position: number;
  direction: Direction;
  /** RPM */
  speed: number;
  /** amperes */
  current: number;
}

export interface Gains {
  kp: number;
  ki: number;
  kd: number;
  /** amperes */
  ratedCurrent: number;
}

/** Single-value settings: the command that writes one, the request that reads it, and its physical form. */
const SETTINGS = {
  response_time: { write: "set_response_time", read: "request_response_time" },
  rated_speed: { write: "set_rated_speed", read: "request_rated_speed" },
  resolution: { write: "set_resolution", read: "request_resolution" },
  ratio: { write: "set_ratio", read: "request_ratio" },
  control: { write: "set_control", read: "request_control" },
  position_mode: { write: "set_position_mode", read: "request_position_mode" },
  direction: { write: "set_direction", read: "request_direction" },
} as const;

/** response_time (us), rated_speed (RPM), resolution (count), ratio (n:1), control ("on"/"off"), position_mode ("absolute"/"relative"), direction ("ccw"/"cw"). */
export type SettingName = keyof typeof SETTINGS;
export const SETTING_NAMES = Object.keys(SETTINGS) as SettingName[];

export interface MotorOptions {
  /** Wait after a settings write before reading it back: the controller is busy writing EEPROM (default 300 ms). */
  settleMs?: number;
}

const sleep = (ms: number): Promise<void> => new Promise((resolve) => setTimeout(resolve, ms));

export class Motor {
  settleMs: number;

  constructor(
    readonly bus: Bus,
    readonly id: number,
    options: MotorOptions = {},
  ) {
    this.settleMs = options.settleMs ?? 300;
  }

  /** True if the controller answers a ping; false on silence (other errors are thrown). */
  async ping(): Promise<boolean> {
    try {
      await this.bus.request(make("request_ping", this.id, {}));
      return true;
    } catch (err) {
      if (err instanceof Error && err.name === "NoAnswerError") return false;
      throw err;
    }
  }

  /** Move to `degrees` (0..655.33, with `direction`) at `rpm`. */
  moveTo(degrees: number, rpm: number, direction: Direction = "ccw"): Promise<void> {
    return this.command(() =>
      make("position_speed", this.id, {
        direction: dir(direction),
        position: toWire(degrees, 0.01),
        speed: toWire(rpm, 0.1),
      }),
    );
  }

  /** Move to `degrees`, arriving in `seconds` (smooth acceleration). */
  moveIn(degrees: number, seconds: number, direction: Direction = "ccw"): Promise<void> {
    return this.command(() =>
      make("accel_position", this.id, {
        direction: dir(direction),
        position: toWire(degrees, 0.01),
        arrival_time: toWire(seconds, 0.1),
      }),
    );
  }

  /** Run at `rpm`, reaching it in `rampSeconds`. */
  run(rpm: number, direction: Direction = "ccw", rampSeconds = 0.1): Promise<void> {
    return this.command(() =>
      make("accel_speed", this.id, {
        direction: dir(direction),
        speed: toWire(rpm, 0.1),
        arrival_time: toWire(rampSeconds, 0.1),
      }),
    );
  }

  /** Control off: the motor is no longer driven and coasts to a stop. */
  release(): Promise<void> {
    return this.bus.send(make("set_control", this.id, { control: 1 }));
  }

  /** Control on: the motor holds its position. */
  hold(): Promise<void> {
    return this.bus.send(make("set_control", this.id, { control: 0 }));
  }

  async readState(): Promise<MotorState> {
    const answer = await this.bus.request(make("request_position", this.id, {}));
    return {
      position: fromWire(answer.position, 0.01),
      direction: answer.direction === 1 ? "cw" : "ccw",
      speed: fromWire(answer.speed, 0.1),
      current: fromWire(answer.current, 0.1),
    };
  }

  async readFirmware(): Promise<number> {
    return (await this.bus.request(make("request_firmware", this.id, {}))).version;
  }

  /** A setting in physical units, or its value name for on/off-like settings. */
  async readSetting(name: SettingName): Promise<number | string> {
    const { read } = SETTINGS[name];
    const answer = (await this.bus.request(make(read, this.id, {}))) as unknown as Record<string, number>;
    const field = fieldOf(messageSpec(SETTINGS[name].write));
    const raw = answer[field.name] ?? NaN;
    const value = field.values[raw] ?? (field.unit !== "" ? fromWire(raw, field.scale) : raw);
    if (name === "response_time" && typeof value === "number") this.bus.responseTimesUs.set(this.id, value); // tighter deadlines
    return value;
  }

  /** Write a setting (physical value or value name), wait for the EEPROM write, read it back; VerifyError if it differs. */
  async writeSetting(name: SettingName, value: number | string): Promise<void> {
    const spec = messageSpec(SETTINGS[name].write);
    const field = fieldOf(spec);
    const raw = wireValue(field.values, field.unit !== "" ? field.scale : 1, value, `${name}`);
    await this.bus.send(make(spec.name, this.id, { [field.name]: raw }));
    if (name === "response_time") this.bus.responseTimesUs.delete(this.id); // old or new: assume the largest until read back
    await sleep(this.settleMs);
    const back = await this.readSetting(name);
    const expected = field.values[raw] ?? (field.unit !== "" ? fromWire(raw, field.scale) : raw);
    if (back !== expected) throw new VerifyError(name, expected, back);
  }

  async readGains(loop: "position" | "speed"): Promise<Gains> {
    const answer = await this.bus.request(
      make(loop === "position" ? "request_position_gains" : "request_speed_gains", this.id, {}),
    );
    return { kp: answer.kp, ki: answer.ki, kd: answer.kd, ratedCurrent: fromWire(answer.rated_current, 0.1) };
  }

  /** Write the gains of the position or speed loop (rated current in A) and verify them by reading back. */
  async writeGains(loop: "position" | "speed", gains: Gains): Promise<void> {
    const fields = { kp: gains.kp, ki: gains.ki, kd: gains.kd, rated_current: toWire(gains.ratedCurrent, 0.1) };
    await this.bus.send(make(loop === "position" ? "set_position_gains" : "set_speed_gains", this.id, fields));
    await sleep(this.settleMs);
    const back = await this.readGains(loop);
    const expected = { ...gains, ratedCurrent: fromWire(fields.rated_current, 0.1) };
    if (JSON.stringify(back) !== JSON.stringify(expected)) throw new VerifyError(`${loop} gains`, expected, back);
  }

  private command(build: () => Parameters<Bus["send"]>[0]): Promise<void> {
    try {
      return this.bus.send(build());
    } catch (err) {
      return Promise.reject(err);
    }
  }
}

const dir = (direction: Direction): number => {
  if (direction !== "ccw" && direction !== "cw")
    throw new RangeError(`direction ${JSON.stringify(direction)}: use "ccw" or "cw"`);
  return direction === "cw" ? 1 : 0;
};

function fieldOf(spec: ReturnType<typeof messageSpec>): ReturnType<typeof messageSpec>["fields"][number] {
  const field = spec.fields[0];
  if (field === undefined) throw new Error(`${spec.name} has no field`);
  return field;
}

/** A value name ("off") or a physical number -> the wire integer. */
function wireValue(
  values: Readonly<Record<number, string>>,
  scale: number,
  value: number | string,
  setting: string,
): number {
  if (typeof value === "string") {
    const entry = Object.entries(values).find(([, n]) => n === value);
    if (entry === undefined)
      throw new RangeError(
        `${setting} = ${JSON.stringify(value)}: use one of ${Object.values(values).join(", ") || "a number"}`,
      );
    return Number(entry[0]);
  }
  return toWire(value, scale);
}
