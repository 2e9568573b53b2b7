// Direct mode at parity with the server, op by op: the same requests and answers as the server's
// worker (dashboard/worker.py), carried out in the page by the TypeScript library over Web Serial.
// Discovery across the 18 rates with each controller's product line, settings read and written
// with read-back, the step response with its figures (one definition: spec/vectors/step-figures.json),
// backup and restore in the CLI's file format with the restore journal in localStorage, ID, baud
// rate and factory reset with the server's confirmations, zero. Each motor is driven at the rate
// it was found at: the bus switches rate before talking to it.
const VERIFY_MS = 1500; // how long a changed ID or rate is looked for (the EEPROM busy window, and more)
const ZERO_WAIT_MS = 1000;
const POSITION_LIMIT = 655.33;

const MC = ["mc", "unknown"]; // the lines the library's Motor drives (MC, BLMC-H)
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

/** The ops direct mode carries out here; the rest are the DirectLink's own (watch, move, frames, estop...). */
export const DIRECT_OPS = new Set([
  "discover",
  "read_settings",
  "set",
  "step",
  "backup",
  "restore",
  "set_zero",
  "change_id",
  "change_baud",
  "factory_reset",
]);

/** The journal of restores under way, per port (Web Serial gives no name: the adapter's USB IDs). */
export function journalFor(link) {
  const info = link.device?.getInfo?.() ?? {};
  const name = info.usbVendorId != null ? `usb-${info.usbVendorId}-${info.usbProductId}` : "serial";
  return new link.lib.StorageJournal(localStorage, name);
}

/** Restores that did not finish on this port: [{id, file}]. */
export function pendingRestores(link) {
  const journal = journalFor(link);
  return [...link.known.keys()].map((id) => ({ id, file: journal.pending(id) })).filter((p) => p.file);
}

export async function directOp(link, op, args) {
  const lib = link.lib;
  switch (op) {
    case "discover":
      return discover(link, args.rates ?? null);
    case "read_settings": {
      const line = link.target(args.id).line;
      if (!MC.includes(line)) {
        await link.atRate(args.id); // another line: its own table (spec/lines.json), the settings it has
        return { id: args.id, settings: await lib.readLineSettings(link.bus, line, args.id) };
      }
      const motor = await link.at(args.id);
      return { id: args.id, settings: await motor.readSettings() };
    }
    case "set": {
      const line = link.target(args.id).line;
      if (!MC.includes(line)) {
        await link.atRate(args.id);
        const value = await lib.setLineSetting(link.bus, line, args.id, args.name, args.value);
        return { id: args.id, name: args.name, value, verified: true };
      }
      const motor = await link.at(args.id);
      const value = await motor.set(args.name, args.value); // two agreeing reads for shared commands; read back
      return { id: args.id, name: args.name, value, verified: true };
    }
    case "step":
      return step(link, args);
    case "backup": // every motor in its own line's table (the CLI's format)
      return lib.makeBackup(
        link.bus,
        args.ids.map((id) => link.target(id)),
      );
    case "restore": {
      const name = args.name ?? "backup";
      const document = lib.checkBackup(args.document, name); // the whole file first: nothing written from a bad one
      const targets = document.motors.map((m) => link.target(m.id));
      const rows = await lib.restoreBackup(link.bus, document, targets, journalFor(link), name);
      return { changed: rows.map((r) => `ID ${r.id} ${r.setting}: ${r.before} -> ${r.after}`), rows };
    }
    case "set_zero": {
      const motor = await link.at(args.id);
      await link.bus.send(lib.make("reset_position", args.id, {}));
      const deadline = performance.now() + ZERO_WAIT_MS;
      for (;;) {
        const state = await motor.readState();
        if (Math.abs(state.devicePosition) < 1 || performance.now() >= deadline)
          return { id: args.id, device_position: state.devicePosition, position: state.position };
        await sleep(50);
      }
    }
    case "change_id":
      return changeId(link, args.id, args.new_id);
    case "change_baud":
      return changeBaud(link, args.id, args.baudrate);
    case "factory_reset": {
      const expected = `RESET ${args.id}`;
      if (args.confirm !== expected)
        throw new Error(`factory_reset: erases every setting of ID ${args.id}; confirm by typing '${expected}'`);
      await link.at(args.id);
      await link.bus.send(lib.make("factory_reset", args.id, {}));
      link.forget(args.id);
      return { id: args.id, note: "it comes back as ID 0 at 9600 bps: discover again at 9600" };
    }
    default:
      return undefined;
  }
}

async function discover(link, rates) {
  const lib = link.lib;
  link.watched = [];
  const list = (found) =>
    found.map((f) => ({ id: f.id, baudrate: f.baudrate, firmware: f.firmware, line: f.line, collision: f.collision }));
  const found = await lib.discover(link.bus, {
    rates: rates ?? undefined,
    onProgress: (p) =>
      link.emit("progress", {
        rate: p.rate,
        index: p.rateIndex,
        total: p.ratesTotal,
        walking_id: p.walkingId,
        found: p.found.map((f) => f.id),
        motors: list(p.found),
        phase: p.phase,
      }),
    onRateSkipped: (_rate, reason) => link.emit("motor_error", { id: "-", message: reason, kind: "info" }),
  });
  const scanned = rates ? new Set(rates) : null;
  for (const [id, known] of link.known) if (!scanned || scanned.has(known.baudrate)) link.known.delete(id);
  for (const f of list(found)) if (!f.collision) link.known.set(f.id, f);
  for (const id of link.known.keys()) link.forgotten.delete(id);
  for (const id of link.known.keys()) link.found.add(id);
  link.watched = [...link.known.keys()].sort((a, b) => a - b);
  const known = link.knownList();
  link.emit("motors", { motors: known });
  // a restore that stopped (the tab closed, the cable pulled) is said, as `nurimc restore` says it
  for (const { id, file } of pendingRestores(link))
    link.emit("motor_error", {
      id,
      kind: "info",
      message: `incomplete restore of ${file}: restore it again (only what still differs is written)`,
    });
  return { motors: list(found), known };
}

async function step(link, { id, amplitude, rpm, duration }) {
  const lib = link.lib;
  const motor = await link.at(id);
  const start = (await motor.readState()).devicePosition;
  const target = Math.round((start + amplitude) * 100) / 100;
  if (Math.abs(target) > POSITION_LIMIT)
    throw new Error(
      `step: the target ${target.toFixed(2)} deg is past the device's position range ±${POSITION_LIMIT} deg ` +
        `(the motor is at ${start.toFixed(2)} deg in the device's frame); use a smaller step, move back, or set zero here first`,
    );
  const stops = link.bus.stops;
  const paused = link.watched;
  link.watched = []; // the step's own readings, as fast as the bus allows
  try {
    await motor.moveTo(target, rpm ? { rpm } : { seconds: 0.5 });
    const began = performance.now();
    const times = [0];
    const positions = [start];
    while (performance.now() - began < duration * 1000) {
      link.bus.assertNoStopSince(stops); // the E-STOP ends the run
      const state = await motor.readState();
      const t = (performance.now() - began) / 1000;
      times.push(Math.round(t * 10000) / 10000);
      positions.push(state.devicePosition);
      link.emit("samples", {
        rows: [
          [
            id,
            (performance.now() - link.origin) / 1000,
            state.position,
            state.speed,
            state.current,
            state.devicePosition,
          ],
        ],
      });
    }
    const f = lib.stepFigures(times, positions, start, target);
    return {
      id,
      start,
      target,
      times,
      positions,
      rise_time: f.rise,
      overshoot: Math.round(f.overshoot * 100) / 100,
      settled: f.settled,
      settling_time: f.settling,
      final_error: Math.round(f.finalError * 1000) / 1000,
    };
  } finally {
    link.watched = paused;
  }
}

async function answers(link, id, windowMs) {
  const deadline = performance.now() + windowMs;
  do {
    try {
      await link.bus.request(link.lib.make("request_ping", id, {}), { retries: 0 });
      return true;
    } catch (error) {
      if (error.name !== "NoAnswerError" && error.name !== "ControllerBusyError") throw error;
    }
  } while (performance.now() < deadline);
  return false;
}

async function changeId(link, id, newId) {
  if (!Number.isInteger(newId) || newId < 0 || newId > 254)
    throw new Error(`change_id: new ID ${newId} is out of range 0..254`);
  if (newId === id) throw new Error(`change_id: ID ${id} already has that ID`);
  if (link.known.has(newId)) throw new Error(`ID ${newId} is already taken by a known motor; pick a free ID`);
  const old = link.target(id);
  await link.at(id);
  if (await answers(link, newId, 0))
    throw new Error(`ID ${newId} already answers at ${link.bus.baudRate} bps; pick a free ID (discover to see them)`);
  await link.bus.send(link.lib.make("set_id", id, { new_id: newId }));
  if (!(await answers(link, newId, VERIFY_MS))) {
    const stillOld = await answers(link, id, 0);
    throw new Error(
      `ID ${id} -> ${newId} did not take: ${stillOld ? `the controller still answers at ID ${id}` : "it answers at neither ID; discover again"}`,
    );
  }
  link.forget(id);
  link.known.set(newId, { ...old, id: newId });
  link.found.add(newId);
  link.watched = [...link.known.keys()].sort((a, b) => a - b);
  link.emit("motors", { motors: link.knownList() });
  return { id, new_id: newId };
}

async function changeBaud(link, id, rate) {
  const lib = link.lib;
  if (!lib.BAUD_RATES.includes(rate))
    throw new Error(`change_baud: baudrate must be one of ${lib.BAUD_RATES.join(", ")}`);
  const old = link.target(id);
  await link.at(id);
  await link.bus.send(lib.make("set_baud", id, { baud_index: lib.BAUD_RATES.indexOf(rate) }));
  // the frame must have left the wire before the host's rate changes
  await sleep(link.lib.wireTimeMs(8, old.baudrate) + link.bus.timing.latencyMs + link.bus.timing.marginMs);
  await link.bus.setBaudRate(rate);
  if (await answers(link, id, VERIFY_MS)) {
    link.known.set(id, { ...old, baudrate: rate });
    link.emit("motors", { motors: link.knownList() });
    return { id, baudrate: rate };
  }
  for (const candidate of [old.baudrate, ...lib.BAUD_RATES.filter((r) => r !== old.baudrate && r !== rate)]) {
    await link.bus.setBaudRate(candidate);
    if (await answers(link, id, 0)) {
      link.known.set(id, { ...old, baudrate: candidate });
      throw new Error(`ID ${id} did not move to ${rate} bps; it answers at ${candidate} bps`);
    }
  }
  throw new Error(`ID ${id} is lost after the baud change: no answer at any rate; check wiring and power`);
}

/** The settings editor's catalogue, as the server gives it (dashboard/commands.py, settings_catalogue). */
export function settingsCatalogue(lib) {
  return lib.SETTINGS.map((s) => {
    const choices = Object.values(s.values);
    return {
      name: s.name,
      doc: s.doc,
      unit: s.unit,
      range: lib.describeSetting(s),
      choices,
      min: choices.length ? null : s.physicalMin,
      max: choices.length ? null : s.physicalMax,
      step: s.wireUnit ? s.scale : 1,
      writable: s.command !== null,
    };
  });
}
