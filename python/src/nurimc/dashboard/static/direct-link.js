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
          rows.push([id, (performance.now() - this.origin) / 1000, s.position, s.speed, s.current, s.devicePosition]);
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
            found.push({ id, baudrate: this.baudRate, firmware: await this.motor(id).get("firmware") });
        }
        return { motors: found };
      }
      case "watch":
        this.watched = args.ids;
        return { watching: args.ids };
      case "move": {
        const travel = args.rpm != null ? { rpm: args.rpm } : { seconds: args.seconds };
        const motor = this.motor(args.id);
        await (args.relative ? motor.moveBy(args.degrees, travel) : motor.moveTo(args.degrees, travel));
        return { id: args.id };
      }
      case "run": {
        await this.motor(args.id).run(args.rpm, args.ramp ?? 0.5);
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
            .get("control")
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
