import { HOST_STOP, MAX_ID } from "./core/limits.js";

// Direct mode: no server; the page drives the bus itself through Web Serial and the TypeScript
// library (nurimc.browser.js next to this page). It offers the same requests as the server for
// discovery at one rate, live state, motion and the emergency stop, with the same safety rules:
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
    this.watched = [];
    this.origin = performance.now();
  }

  async connect() {
    const device = await navigator.serial.requestPort();
    const port = await this.lib.WebSerialPort.open(device, this.baudRate);
    this.frames = null; // the raw view's capture, when on
    this.bus = new this.lib.Bus(port, { onTraffic: (event) => this.traffic(event) });
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

  async poll() {
    while (this.connected) {
      const started = performance.now();
      const rows = [];
      for (const id of this.watched) {
        try {
          const s = await this.motor(id).readState();
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
    return { id, baudrate: this.baudRate, firmware: null };
  }

  async discover(ids) {
    const found = [];
    const candidates = ids ?? Array.from({ length: MAX_ID + 1 }, (_, id) => id);
    for (const [index, id] of candidates.entries()) {
      if (index % 8 === 0)
        this.emit("progress", {
          rate: this.baudRate,
          index: 0,
          total: 1,
          walking_id: id,
          found: found.map((m) => m.id),
          motors: found,
        });
      try {
        await this.bus.request(this.lib.make("request_ping", id, {}), { retries: 0 });
      } catch (error) {
        if (error.name === "NoAnswerError" || error.name === "ControllerBusyError") continue;
        throw error;
      }
      const info = this.info(id);
      info.firmware = await this.motor(id)
        .get("firmware")
        .catch(() => null);
      found.push(info);
      this.found.add(id);
      this.emit("progress", {
        rate: this.baudRate,
        index: 0,
        total: 1,
        walking_id: id,
        found: found.map((m) => m.id),
        motors: found,
      });
    }
    return { motors: found };
  }

  async request(op, args = {}) {
    switch (op) {
      case "discover":
        return this.discover(args.ids ?? null);
      case "watch":
        this.watched = args.ids;
        return { watching: args.ids };
      case "move": {
        const travel = args.rpm != null ? { rpm: args.rpm } : { seconds: args.seconds };
        const motor = this.motor(args.id);
        await (args.relative ? motor.moveBy(args.degrees, travel) : motor.moveTo(args.degrees, travel));
        return { id: args.id };
      }
      case "run":
        await this.motor(args.id).run(args.rpm, args.ramp ?? 0.5);
        return { id: args.id };
      case "release":
        await this.motor(args.id).release();
        return { id: args.id };
      case "hold":
        await this.motor(args.id).hold();
        return { id: args.id };
      case "read_settings":
        return { settings: { control: await this.motor(args.id).get("control") } };
      case "frames":
        this.frames = args.on ? [] : null;
        return { on: Boolean(args.on), recent: [] };
      case "estop":
        return this.emergencyStop();
      default:
        throw new Error(`${op} needs the server in this version: run \`nurimc dashboard\` and open its address`);
    }
  }

  /** Control off to every motor (broadcast), ahead of everything queued; then each known motor read back. */
  async emergencyStop() {
    const off = (id) => this.lib.make("set_control", id, { control: 1 });
    await this.bus.emergency(off(this.lib.BROADCAST_ID));
    const ids = [...new Set([...this.found, ...this.watched, ...this.motors.keys()])].filter((id) => id <= MAX_ID);
    const deadline = performance.now() + ESTOP_VERIFY_MS;
    const control = {};
    for (const id of ids) {
      for (;;) {
        try {
          control[id] = await this.motor(id).get("control");
        } catch (error) {
          control[id] = `unknown: ${error.message}`;
        }
        if (control[id] === "off" || performance.now() >= deadline) break;
        await this.bus.send(off(id)).catch(() => {}); // not off yet (busy, or a frame lost): tell it again
        await new Promise((resolve) => setTimeout(resolve, HOST_STOP.recheckMs)); // spec/host.json "stop"
      }
    }
    const stopped = ids.filter((id) => control[id] === "off");
    const notConfirmed = ids.filter((id) => control[id] !== "off");
    const ok = stopped.length > 0 && notConfirmed.length === 0; // never "ok" with nothing read back
    const result = { rates: [this.baudRate], control, stopped, not_confirmed: notConfirmed, ok, verified: ok };
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
