/**
 * A motor handle: one controller ID on a Bus, in physical units with the Python library's
 * meaning (python/src/nurimc/motor.py): positions in signed degrees and speeds in signed
 * RPM, counter-clockwise positive; seconds, amperes; settings by name in their units.
 *
 * - `moveTo` goes to an absolute signed position (±655.33°), `moveBy` moves by a signed
 *   amount; both honour the controller's position mode (read once) and switch control on
 *   first if it is off. `run` turns at a signed speed (0 is refused: `release` or `hold`).
 * - `hold` switches control on and, in absolute mode, re-targets the present position.
 * - `readState` reports the device's signed position and a continuous position that
 *   unwraps the 655.36° counter (host-side multi-turn tracking).
 * - Limits come from spec/host.json (LIMITS) and spec/protocol.json; a value is rounded to
 *   the nearest wire step first, then range-checked (units.ts); the error comes before
 *   anything is sent.
 */
import type { Bus } from "./bus/client.js";
import { VerifyError } from "./bus/errors.js";
import { fieldsOf, type Message, type MessageOf, make } from "./codec.js";
import { LIMITS } from "./generated/host.js";
import { SETTINGS, type SettingSpec, type SettingValue, setting, settingFromWire, settingToWire } from "./settings.js";
import { arrivalToWire, fromWire, positionToWire, signedFromWire, speedToWire } from "./units.js";

/** Reads taken at most to find two that agree before a write is built from them. */
export const CONFIRM_READS = 4;

/** Reads a write was to be built from did not agree (noise that passed the checksum): nothing was written. */
export class UnconfirmedReadError extends Error {
  override name = "UnconfirmedReadError";
}

export interface MotorState {
  id: number;
  /** degrees, continuous across the counter's wraps (host-side multi-turn tracking) */
  position: number;
  /** degrees, signed, as the device reported it (-655.35..655.35) */
  devicePosition: number;
  /** RPM: the magnitude from position feedback; `readSpeed()` gives it signed */
  speed: number;
  /** amperes */
  current: number;
  /** "ccw" or "cw": the sign of devicePosition */
  direction: "ccw" | "cw";
}

/** How a move travels: at a speed (§1) or arriving after a time (§2). */
export type Travel = { rpm: number; seconds?: undefined } | { seconds: number; rpm?: undefined };

/** The speed `hold()` uses to re-target the present position. */
export const HOLD_RPM = 10;

/**
 * Host-side multi-turn tracking: each step between two readings is taken the shortest way
 * round the 655.36° counter, so the continuous position is right while the motor turns
 * less than half a wrap between readings (at 100 RPM, read at least every 0.5 s).
 */
export class TurnTracker {
  private last: number | null = null;
  position = 0;

  update(deviceDegrees: number): number {
    const wrap = LIMITS.positionWrapDeg;
    if (this.last === null) this.position = deviceDegrees;
    else {
      const step = ((((deviceDegrees - this.last + wrap / 2) % wrap) + wrap) % wrap) - wrap / 2;
      this.position += step;
    }
    this.last = deviceDegrees;
    this.position = Math.round(this.position * 1e6) / 1e6;
    return this.position;
  }

  reset(): void {
    this.last = null;
    this.position = 0;
  }
}

export class Motor {
  readonly tracker = new TurnTracker();
  /** The position mode, read before the first move (null: not known yet). */
  private relative: boolean | null = null;
  /** Whether control is off (null: not known yet). */
  private released: boolean | null = null;
  /** The bus's emergency-stop count when `released` was last known (a stop turns control off). */
  private stopsSeen = 0;

  constructor(
    readonly bus: Bus,
    readonly id: number,
  ) {}

  // -- builders (no I/O): for batches, `bus.send(...motors.map((m) => m.makeRun(30)))` ------

  /** The position command for a signed target (CCW +), at `{ rpm }` (§1) or arriving in `{ seconds }` (§2). */
  makeMoveTo(degrees: number, travel: Travel): MessageOf<"position_speed"> | MessageOf<"accel_position"> {
    const rpm = travel.rpm;
    const seconds = travel.seconds;
    if ((rpm === undefined) === (seconds === undefined))
      throw new TypeError("give exactly one of { rpm } (speed) or { seconds } (arrival time)");
    const { direction, wire: position } = positionToWire(degrees);
    if (rpm !== undefined)
      return make("position_speed", this.id, { direction, position, speed: speedToWire(Math.abs(rpm)).wire });
    return make("accel_position", this.id, { direction, position, arrival_time: arrivalToWire(seconds as number) });
  }

  /** The speed command: signed RPM (CCW +), reached in `rampSeconds` (§3). */
  makeRun(rpm: number, rampSeconds = 0.1): MessageOf<"accel_speed"> {
    const { direction, wire: speed } = speedToWire(rpm);
    return make("accel_speed", this.id, { direction, speed, arrival_time: arrivalToWire(rampSeconds) });
  }

  makeRelease(): MessageOf<"set_control"> {
    return make("set_control", this.id, { control: 1 });
  }

  // -- motion -----------------------------------------------------------------

  /** Go to an absolute signed position (the device's frame, ±655.33°). In relative mode the step from here is sent. */
  async moveTo(degrees: number, travel: Travel): Promise<void> {
    const stops = this.sinceStops();
    let command = this.makeMoveTo(degrees, travel);
    if (await this.isRelative()) command = this.makeMoveTo(degrees - (await this.readState()).devicePosition, travel);
    await this.enableIfReleased(stops);
    this.bus.assertNoStopSince(stops);
    await this.bus.send(command);
  }

  /** Move by a signed amount from where the motor is. */
  async moveBy(degrees: number, travel: Travel): Promise<void> {
    const stops = this.sinceStops();
    let command: Message;
    if (await this.isRelative()) command = this.makeMoveTo(degrees, travel);
    else command = this.makeMoveTo((await this.readState()).devicePosition + degrees, travel);
    await this.enableIfReleased(stops);
    this.bus.assertNoStopSince(stops);
    await this.bus.send(command);
  }

  /** Turn at a signed speed (CCW +), reached in `rampSeconds`. */
  async run(rpm: number, rampSeconds = 0.1): Promise<void> {
    const stops = this.sinceStops();
    const command = this.makeRun(rpm, rampSeconds);
    await this.enableIfReleased(stops);
    this.bus.assertNoStopSince(stops);
    await this.bus.send(command);
  }

  /** Control off: the motor is no longer driven and coasts to a stop. */
  async release(): Promise<void> {
    await this.bus.send(this.makeRelease());
    this.released = true;
  }

  /** Control on, holding the present position: in absolute mode the present position becomes the target. */
  async hold(): Promise<void> {
    const stops = this.sinceStops();
    await this.bus.send(make("set_control", this.id, { control: 0 }));
    this.released = false;
    if (await this.isRelative()) return; // a relative target of 0 would be no move: control on holds here
    const state = await this.readState();
    this.bus.assertNoStopSince(stops);
    await this.bus.send(this.makeMoveTo(state.devicePosition, { rpm: HOLD_RPM }));
  }

  // -- feedback -----------------------------------------------------------------

  /** A MotorState from a position feedback answer (also for answers read another way). */
  stateFrom(answer: MessageOf<"position_feedback">): MotorState {
    const device = signedFromWire(answer.direction, answer.position, 0.01);
    return {
      id: this.id,
      position: this.tracker.update(device),
      devicePosition: device,
      speed: fromWire(answer.speed, 0.1),
      current: fromWire(answer.current, 0.1),
      direction: answer.direction === 1 ? "cw" : "ccw",
    };
  }

  async readState(): Promise<MotorState> {
    return this.stateFrom(await this.bus.request(make("request_position", this.id, {})));
  }

  /** Signed speed in RPM (CCW +) from speed feedback (§20). */
  async readSpeed(): Promise<number> {
    const answer = await this.bus.request(make("request_speed", this.id, {}));
    return signedFromWire(answer.direction, answer.speed, 0.1);
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

  // -- settings -------------------------------------------------------------------

  /** A setting by name ("ratio", "position-kp", "control", "firmware", ...) in its physical unit or value name. */
  async get(name: string): Promise<SettingValue> {
    const spec = setting(name);
    const raw = await this.readRaw(spec);
    return settingFromWire(spec, raw);
  }

  /** Every setting, reading each feedback request once. */
  async readSettings(): Promise<Record<string, SettingValue>> {
    const answers = new Map<string, Record<string, number>>();
    const out: Record<string, SettingValue> = {};
    for (const spec of SETTINGS) {
      let answer = answers.get(spec.answer);
      if (answer === undefined) {
        answer = fieldsOf(await this.bus.request(make(spec.request as string, this.id, {})));
        answers.set(spec.answer, answer);
      }
      const raw = answer[spec.field] ?? NaN;
      this.remember(spec, raw);
      out[spec.name] = settingFromWire(spec, raw);
    }
    return out;
  }

  /**
   * Write a setting in its physical unit (or a value name), then read it back: VerifyError if
   * the controller did not take it. Gains and rated current share one command: the others
   * are read first and written unchanged. Returns the value as stored (12.34:1 -> 12.3).
   */
  async set(name: string, value: SettingValue): Promise<SettingValue> {
    const spec = setting(name);
    if (spec.command === null) throw new RangeError(`${spec.name} is read-only`);
    const raw = settingToWire(spec, value);
    let fields: Record<string, number> = { [spec.field]: raw };
    if (spec.command === "set_position_gains" || spec.command === "set_speed_gains") {
      const current = await this.confirmedFields(spec); // never a value noise put there
      fields = { ...current, [spec.field]: raw };
    }
    await this.bus.send(make(spec.command as string, this.id, fields));
    if (spec.name === "response-time") this.bus.responseTimesUs.delete(this.id); // old or new: the largest until read back
    // the bus holds the read-back until the EEPROM busy window has ended; every field written must show
    const back = fieldsOf(await this.bus.request(make(spec.request as string, this.id, {})));
    this.remember(spec, back[spec.field] ?? NaN);
    for (const [field, wrote] of Object.entries(fields)) {
      if (back[field] !== wrote) {
        this.relative = null;
        const which = SETTINGS.find((s) => s.command === spec.command && s.field === field) ?? spec;
        throw new VerifyError(which.name, settingFromWire(which, wrote), settingFromWire(which, back[field] ?? NaN));
      }
    }
    return settingFromWire(spec, raw);
  }

  /**
   * A setting's answer once two reads agree (at most CONFIRM_READS): noise that keeps the 8-bit
   * checksum changes an answer at random, and a write built from one read would carry it into
   * the controller's EEPROM (docs/library.md, Verified writes; as nurimc.procedures.settings.confirmed_answer).
   */
  private async confirmedFields(spec: SettingSpec): Promise<Record<string, number>> {
    const seen: string[] = [];
    for (let i = 0; i < CONFIRM_READS; i++) {
      const answer = fieldsOf(await this.bus.request(make(spec.request as string, this.id, {})));
      const key = JSON.stringify(answer);
      if (seen.includes(key)) return answer;
      seen.push(key);
    }
    throw new UnconfirmedReadError(
      `ID ${this.id}: ${CONFIRM_READS} reads of ${spec.answer} all differ (${seen.join(", ")}): noise on the bus ` +
        "gets past the checksum, so nothing was written; check termination, grounding and the cable, then try again",
    );
  }

  // -- internals --------------------------------------------------------------------

  private async readRaw(spec: SettingSpec): Promise<number> {
    const answer = fieldsOf(await this.bus.request(make(spec.request as string, this.id, {})));
    const raw = answer[spec.field] ?? NaN;
    this.remember(spec, raw);
    return raw;
  }

  private remember(spec: SettingSpec, raw: number): void {
    if (spec.name === "response-time")
      this.bus.responseTimesUs.set(this.id, raw * 100); // tighter deadlines
    else if (spec.name === "position-mode") this.relative = raw === 1;
    else if (spec.name === "control") this.released = raw === 1;
  }

  /**
   * The bus's emergency-stop count at the start of a motion: each later step checks it, so an
   * operation begun before a stop sends nothing after it. A stop since the last call turned
   * control off, so what was known about control is forgotten (read again before moving).
   */
  private sinceStops(): number {
    if (this.stopsSeen !== this.bus.stops) {
      this.stopsSeen = this.bus.stops;
      this.released = null;
    }
    return this.stopsSeen;
  }

  private async isRelative(): Promise<boolean> {
    if (this.relative === null) await this.readRaw(setting("position-mode"));
    return this.relative === true;
  }

  /** Control on if it is off (read once if unknown); the motion that follows waits out the busy window this starts. */
  private async enableIfReleased(stops: number): Promise<void> {
    if (this.released === null) await this.readRaw(setting("control"));
    this.bus.assertNoStopSince(stops);
    if (this.released === true) {
      await this.bus.send(make("set_control", this.id, { control: 0 }));
      this.released = false;
    }
  }
}
