// Direct mode: no server; the page drives the bus itself through Web Serial and the
// TypeScript library (nurimc.browser.js next to this page). It offers the same requests
// as the server for discovery at one rate, live state, motion and the emergency stop.
const LIVE_HZ = 100;

export class DirectLink {
  constructor(lib, baudRate) {
    this.lib = lib;
    this.baudRate = baudRate;
    this.handlers = new Map();
    this.motors = new Map();
    this.watched = [];
    this.origin = performance.now();
  }

  async connect() {
    const device = await navigator.serial.requestPort();
    this.bus = new this.lib.Bus(await this.lib.WebSerialPort.open(device, this.baudRate));
    this.poll();
    return this;
  }

  motor(id) {
    if (!this.motors.has(id)) this.motors.set(id, new this.lib.Motor(this.bus, id));
    return this.motors.get(id);
  }

  async poll() {
    for (;;) {
      const started = performance.now();
      const rows = [];
      for (const id of this.watched) {
        try {
          const s = await this.motor(id).readState();
          const signed = s.direction === "cw" ? -s.position : s.position;
          rows.push([id, (performance.now() - this.origin) / 1000, signed, s.speed, s.current, signed]);
        } catch (error) {
          this.emit("motor_error", { id, message: error.message });
        }
      }
      if (rows.length) this.emit("samples", { rows });
      const wait = 1000 / LIVE_HZ - (performance.now() - started);
      await new Promise((r) => setTimeout(r, Math.max(wait, this.watched.length ? 0 : 200)));
    }
  }

  async request(op, args = {}) {
    const signed = (value) => [Math.abs(value), value < 0 ? "cw" : "ccw"];
    switch (op) {
      case "discover": {
        const found = [];
        for (let id = 0; id <= 254; id++) {
          if (id % 8 === 0)
            this.emit("progress", {
              rate: this.baudRate,
              index: 0,
              total: 1,
              walking_id: id,
              found: found.map((m) => m.id),
            });
          if (await this.motor(id).ping())
            found.push({ id, baudrate: this.baudRate, firmware: await this.motor(id).readFirmware() });
        }
        return { motors: found };
      }
      case "watch":
        this.watched = args.ids;
        return { watching: args.ids };
      case "move": {
        if (args.relative) throw new Error("move by is not available in direct mode; give a target position");
        const [degrees, direction] = signed(args.degrees);
        await (args.rpm != null
          ? this.motor(args.id).moveTo(degrees, args.rpm, direction)
          : this.motor(args.id).moveIn(degrees, args.seconds, direction));
        return { id: args.id };
      }
      case "run": {
        const [rpm, direction] = signed(args.rpm);
        await this.motor(args.id).run(rpm, direction, args.ramp ?? 0.5);
        return { id: args.id };
      }
      case "release":
        await this.motor(args.id).release();
        return { id: args.id };
      case "hold":
        await this.motor(args.id).hold();
        return { id: args.id };
      case "estop": {
        await this.bus.send(this.lib.make("set_control", 255, { control: 1 }));
        const control = {};
        for (const id of this.motors.keys())
          control[id] = await this.motor(id)
            .readSetting("control")
            .catch((e) => `unknown: ${e.message}`);
        this.emit("estop", { rates: [this.baudRate], control });
        return { rates: [this.baudRate], control };
      }
      default:
        throw new Error(`${op} needs the server in this version: run \`nurimc dashboard\` and open its address`);
    }
  }

  on(type, handler) {
    if (!this.handlers.has(type)) this.handlers.set(type, []);
    this.handlers.get(type).push(handler);
  }

  emit(type, message) {
    for (const handler of this.handlers.get(type) ?? []) handler(message);
  }
}
