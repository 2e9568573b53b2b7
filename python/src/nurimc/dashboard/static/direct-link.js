import { HOST_STOP, MAX_ID } from "./core/limits.js";
import { DIRECT_OPS, directOp } from "./direct-ops.js";

// Direct mode: no server; the page drives the bus itself through Web Serial and the TypeScript
// library (nurimc.browser.js next to this page). It offers the same requests as the server
// (direct-ops.js: discovery across rates with product lines, settings, step response, backup and
// restore, ID / baud / factory reset), each motor at the rate it was found at, with the same safety rules:
// the stop jumps the client's queue (Bus.emergency: everything queued is cancelled, nothing of
// a motion begun before it is sent after it) and is verified by reading every motor's control
// back, sent again to a motor that does not read off, for up to ESTOP_VERIFY_MS.
const LIVE_HZ = 100;
const ESTOP_VERIFY_MS = HOST_STOP.verifyMs; // spec/host.json "stop", the same window as the server's (docs/service.md)

export class DirectLink {
  constructor(lib, baudRate) {
    this.lib = lib;
    this.baudRate = baudRate;
    this.handlers = new Map();
    this.motors = new Map();
    this.found = new Set();
    this.known = new Map(); // id -> {id, baudrate, firmware, line}: where each motor answers
    this.forgotten = new Set();
    this.chain = Promise.resolve(); // one operation at a time: a rate switch and its requests go together
    this.watched = [];
    this.origin = performance.now();
  }

  async connect() {
    const device = await navigator.serial.requestPort();
    this.device = device;
    const port = await this.lib.WebSerialPort.open(device, this.baudRate);
    this.frames = null; // the raw view's capture, when on
    this.bus = new this.lib.Bus(port, {
      onTraffic: (event) => this.traffic(event),
      // a USB adapter's latency (FTDI's 16 ms timer) and the browser's own scheduling: the
      // deadlines of an unknown adapter, as the Python library gives a real port (spec/host.json)
      timing: { latencyMs: this.lib.HOST_TIMING.usbAdapterLatencyMs },
    });
    this.connected = true;
    this.poll();
    return this;
  }

  /** The bus client's counters, for the status bar. */
  stats() {
    const s = this.bus?.stats;
    if (!s) return null;
    return {
      requests: s.requests + s.commands, // frames sent (retries count as requests)
      answers: s.requests - s.noAnswer - s.corrupted, // calls answered
      errors: s.noAnswer + s.corrupted,
      stale: s.staleFrames,
      busy_waits: s.busyWaits,
    };
  }

  traffic({ direction, time, message }) {
    if (!this.frames) return;
    const { name, id, ...fields } = message;
    let hex = "";
    try {
      hex = this.lib.toHex(this.lib.encode(message));
    } catch {
      hex = "";
    }
    this.frames.push({ t: time / 1000, dir: direction, id, name, fields, hex: hex.replace(/(..)(?!$)/g, "$1 ") });
  }

  motor(id) {
    if (!this.motors.has(id)) this.motors.set(id, new this.lib.Motor(this.bus, id));
    return this.motors.get(id);
  }

  /** Where a motor answers and its line (discovery's find; the bus's rate if not found yet). */
  target(id) {
    return this.known.get(id) ?? { id, baudrate: this.bus.baudRate, firmware: null, line: "mc" };
  }

  /** The motor's handle, with the bus at the motor's rate; only MC-line motors are driven here. */
  async at(id) {
    const target = this.target(id);
    if (target.line !== "mc" && target.line !== "unknown")
      throw new Error(
        `ID ${id} speaks the ${target.line} line: its settings and the E-STOP work here; moving it needs the Python console (nurimc dashboard) in this version`,
      );
    await this.atRate(id);
    return this.motor(id);
  }

  /** The bus at the motor's rate (any line). */
  async atRate(id) {
    const target = this.target(id);
    if (this.bus.baudRate !== target.baudrate) await this.bus.setBaudRate(target.baudrate);
    return target;
  }

  /** Run `task` after every operation begun before it (the E-STOP's broadcast never waits for this). */
  serial(task) {
    const stops = this.bus.stops; // an operation asked for before a stop never starts after it
    const run = this.chain.then(() => {
      this.bus.assertNoStopSince(stops);
      return task();
    });
    this.chain = run.catch(() => undefined);
    return run;
  }

  forget(id) {
    this.forgotten.add(id); // gone from this ID (new ID, factory reset): not read back by the E-STOP
    this.known.delete(id);
    this.found.delete(id);
    this.motors.delete(id);
    this.watched = this.watched.filter((w) => w !== id);
  }

  knownList() {
    return [...this.known.values()].sort((a, b) => a.id - b.id);
  }

  async poll() {
    while (this.connected) {
      const started = performance.now();
      const rows = [];
      for (const id of this.watched) {
        if (!this.watched.includes(id)) continue; // forgotten meanwhile (new ID, factory reset)
        if (!["mc", "unknown"].includes(this.target(id).line)) continue; // live state of MC-line motors only
        try {
          const s = await this.serial(async () => (await this.at(id)).readState());
          rows.push([id, (performance.now() - this.origin) / 1000, s.position, s.speed, s.current, s.devicePosition]);
        } catch (error) {
          if (error.name !== "CancelledError") this.emit("motor_error", { id, message: error.message, kind: "error" });
        }
      }
      if (rows.length) this.emit("samples", { rows });
      if (this.frames?.length) this.emit("frames", { frames: this.frames.splice(0) });
      const wait = 1000 / LIVE_HZ - (performance.now() - started);
      await new Promise((r) => setTimeout(r, Math.max(wait, this.watched.length ? 0 : 200)));
    }
  }

  info(id) {
    return { id, baudrate: this.bus?.baudRate ?? this.baudRate, firmware: null };
  }

  async request(op, args = {}) {
    if (DIRECT_OPS.has(op)) return this.serial(() => directOp(this, op, args));
    switch (op) {
      case "watch":
        this.watched = args.ids;
        return { watching: args.ids };
      case "move": {
        const travel = args.rpm != null ? { rpm: args.rpm } : { seconds: args.seconds };
        await this.serial(async () => {
          const motor = await this.at(args.id);
          await (args.relative ? motor.moveBy(args.degrees, travel) : motor.moveTo(args.degrees, travel));
        });
        return { id: args.id };
      }
      case "run":
        await this.serial(async () => (await this.at(args.id)).run(args.rpm, args.ramp ?? 0.5));
        return { id: args.id };
      case "release":
        await this.serial(async () => (await this.at(args.id)).release());
        return { id: args.id };
      case "hold":
        await this.serial(async () => (await this.at(args.id)).hold());
        return { id: args.id };
      case "frames":
        this.frames = args.on ? [] : null;
        return { on: Boolean(args.on), recent: [] };
      case "estop":
        return this.emergencyStop();
      default:
        throw new Error(`${op} is not available in direct mode: run \`nurimc dashboard\` and open its address`);
    }
  }

  /** Control off to every motor (broadcast), ahead of everything queued, at the bus's rate and then at
   * every other rate a motor was found at; then each known motor read back at its rate. */
  async emergencyStop() {
    const off = (id) => this.lib.make("set_control", id, { control: 1 });
    const first = this.bus.baudRate;
    await this.bus.emergency(off(this.lib.BROADCAST_ID));
    return this.serial(() => this.verifyStop(first));
  }

  /** The stop at the other rates and lines, then each motor read back (told again until off). */
  async verifyStop(first) {
    const off = (id) => this.lib.make("set_control", id, { control: 1 });
    const rates = [first, ...new Set([...this.known.values()].map((k) => k.baudrate).filter((r) => r !== first))];
    const linesAt = (rate) => new Set([...this.known.values()].filter((k) => k.baudrate === rate).map((k) => k.line));
    for (const [index, rate] of rates.entries()) {
      if (index > 0) {
        await this.bus.setBaudRate(rate);
        await this.bus.emergency(off(this.lib.BROADCAST_ID));
      }
      for (const line of linesAt(rate)) // each other line's own control-off (RSA: 0A, not MC's 0C)
        if (line !== "mc" && line !== "unknown")
          await this.lib.tellInLine(this.bus, line, "set_control", this.lib.BROADCAST_ID, { control: 1 });
    }
    // every motor found (at its rate), and any other watched or driven since (at the bus's rate)
    const known = [...this.known.keys()];
    const ids = [...new Set([...known, ...this.watched, ...this.motors.keys()])].filter(
      (id) => id <= MAX_ID && (this.known.has(id) || !this.forgotten.has(id)),
    );
    const deadline = performance.now() + ESTOP_VERIFY_MS;
    const control = {};
    for (const id of ids) {
      const rate = this.target(id).baudrate;
      if (this.bus.baudRate !== rate) await this.bus.setBaudRate(rate);
      const line = this.target(id).line;
      const mc = line === "mc" || line === "unknown";
      for (;;) {
        try {
          if (mc) control[id] = await this.motor(id).get("control");
          else {
            const answer = await this.lib.askInLine(this.bus, line, "request_control", id);
            control[id] = answer === null ? "unknown: no answer" : answer.control === 1 ? "off" : "on";
          }
        } catch (error) {
          control[id] = `unknown: ${error.message}`;
        }
        if (control[id] === "off" || performance.now() >= deadline) break;
        // not off yet (busy, or a frame lost): tell it again, in its own line
        const again = mc
          ? this.bus.send(off(id))
          : this.lib.tellInLine(this.bus, line, "set_control", id, { control: 1 });
        await again.catch(() => {});
        await new Promise((resolve) => setTimeout(resolve, HOST_STOP.recheckMs)); // spec/host.json "stop"
      }
    }
    const stopped = ids.filter((id) => control[id] === "off");
    const notConfirmed = ids.filter((id) => control[id] !== "off");
    const ok = stopped.length > 0 && notConfirmed.length === 0; // never "ok" with nothing read back
    const result = { rates, control, stopped, not_confirmed: notConfirmed, ok, verified: ok };
    this.emit("estop", result);
    return result;
  }

  on(type, handler) {
    if (!this.handlers.has(type)) this.handlers.set(type, []);
    this.handlers.get(type).push(handler);
  }

  emit(type, message) {
    for (const handler of this.handlers.get(type) ?? []) handler(message);
  }
}
