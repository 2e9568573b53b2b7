/** The EEPROM busy-window rule (docs/protocol.md, Busy window) in the TypeScript bus client. */
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { ControllerBusyError, NoAnswerError } from "../src/bus/errors.js";
import { wireTimeMs } from "../src/bus/timing.js";
import { decode, encode, make } from "../src/codec.js";
import { EEPROM_WRITES, HOST_PROFILES } from "../src/generated/host.js";
import { FakePort } from "./fake-port.js";

/** A port whose controllers (every ID in `ids`) answer pings; records when each frame was written. */
function recording(ids: number[] = [1, 2, 3, 5, 7]) {
  const times: { name: string; id: number; at: number }[] = [];
  const port = new FakePort((written) => {
    const message = decode(written.subarray(0, written[3]! + 4));
    times.push({ name: message.name, id: message.id, at: performance.now() });
    if (message.name === "request_ping" && ids.includes(message.id)) return encode(make("ping", message.id, {}));
    return null;
  });
  return { port, times };
}

const fast = { latencyMs: 1, assumedResponseTimeUs: 100 };
const gains = (id: number) => make("set_position_gains", id, { kp: 10, ki: 0, kd: 1, rated_current: 30 });
const ping = (id: number) => make("request_ping", id, {});
const gap = (times: { at: number }[], a: number, b: number) => times[b]!.at - times[a]!.at;

describe("busy window", () => {
  it("comes from the spec: every settings command, control on/off and factory reset; never motion", () => {
    expect(EEPROM_WRITES).toContain("set_control");
    expect(EEPROM_WRITES).toContain("factory_reset");
    expect(EEPROM_WRITES).not.toContain("position_speed");
    expect(EEPROM_WRITES).not.toContain("reset_position");
    expect(HOST_PROFILES["mc"]!.busyWindowMs).toBe(300);
  });

  it("holds the next frame to the ID until its window has ended", async () => {
    const { port, times } = recording();
    const bus = new Bus(port, { timing: fast, busyWindowMs: 40 });
    await bus.send(gains(1));
    await bus.request(ping(1));
    // the window counts from the end of the gains frame on the wire plus the adapter latency
    expect(gap(times, 0, 1)).toBeGreaterThanOrEqual(40 + wireTimeMs(10, port.baudRate) + fast.latencyMs - 1);
    expect(bus.stats.busyWaits).toBe(1);
  });

  it("does not hold motion, requests or frames to other IDs", async () => {
    const { port } = recording();
    const bus = new Bus(port, { timing: fast, busyWindowMs: 1000 });
    await bus.send(make("position_speed", 1, { direction: 0, position: 100, speed: 10 }));
    await bus.request(ping(1));
    await bus.send(gains(1));
    await bus.request(ping(2)); // ID 2 is free
    await bus.send(make("reset_position", 3, {}));
    await bus.request(ping(3));
    expect(bus.stats.busyWaits).toBe(0);
    expect(bus.busyUntil(1)).toBeGreaterThan(performance.now() + 500);
    expect(bus.busyUntil(2)).toBe(0);
  });

  it("set_id makes the old and the new ID busy; factory_reset also ID 0", async () => {
    const bus = new Bus(recording().port, { timing: fast, busyWindowMs: 1000 });
    await bus.send(make("set_id", 1, { new_id: 2 }), make("factory_reset", 5, {}));
    const now = performance.now();
    for (const id of [1, 2, 5, 0]) expect(bus.busyUntil(id), `ID ${id}`).toBeGreaterThan(now + 900);
    expect(bus.busyUntil(3)).toBe(0);
  });

  it("a broadcast write makes every ID busy for the largest window", async () => {
    const { port, times } = recording();
    const bus = new Bus(port, { timing: fast, busyWindowMs: 10, busyWindowsMs: { 7: 60 } });
    expect(bus.windowMs(255)).toBe(60);
    await bus.send(make("set_control", 255, { control: 0 }));
    await bus.request(ping(3));
    expect(gap(times, 0, 1)).toBeGreaterThanOrEqual(60);
  });

  it("a broadcast frame waits for every ID's window", async () => {
    const { port, times } = recording();
    const bus = new Bus(port, { timing: fast, busyWindowsMs: { 2: 50 } });
    await bus.send(gains(2));
    await bus.send(make("position_speed", 255, { direction: 0, position: 0, speed: 10 }));
    expect(gap(times, 0, 1)).toBeGreaterThanOrEqual(50);
  });

  it("a frame carrying several commands waits for the latest window among its IDs", async () => {
    const { port, times } = recording();
    const bus = new Bus(port, { timing: fast, busyWindowsMs: { 1: 5, 2: 50 } });
    await bus.send(gains(1), gains(2));
    await bus.send(
      make("position_speed", 1, { direction: 0, position: 0, speed: 10 }),
      make("position_speed", 2, { direction: 0, position: 0, speed: 10 }),
    );
    expect(gap(times, 0, 1)).toBeGreaterThanOrEqual(50);
  });

  it("is configurable per ID, per bus, and per product profile, in that order", () => {
    const port = new FakePort();
    expect(new Bus(port).windowMs(4)).toBe(HOST_PROFILES["mc"]!.busyWindowMs);
    expect(new Bus(port, { products: { 4: "blmc-h" } }).windowMs(4)).toBe(HOST_PROFILES["blmc-h"]!.busyWindowMs);
    const bus = new Bus(port, { busyWindowMs: 120, busyWindowsMs: { 4: 80 }, products: { 4: "blmc-h", 5: "blmc-h" } });
    expect(bus.windowMs(4)).toBe(80);
    expect(bus.windowMs(5)).toBe(120);
    expect(bus.windowMs(6)).toBe(120);
    bus.busyWindowsMs.set(6, 0);
    expect(bus.windowMs(6)).toBe(0);
    expect(() => new Bus(port, { products: { 4: "warp" } })).toThrow(/unknown product "warp"/);
    expect(() => new Bus(port, { busyWindowsMs: { 255: 10 } })).toThrow(/not 0..254/);
    expect(() => new Bus(port, { busyWindowMs: Number.NaN })).toThrow(/finite number/);
  });

  it("silence right after a busy window says the controller is busy, not the wiring", async () => {
    const { port } = recording([]); // nobody answers
    const bus = new Bus(port, { timing: fast, busyWindowMs: 30, retries: 0 });
    await bus.send(make("set_ratio", 3, { ratio: 10 }));
    const busy = await bus.request(ping(3)).catch((err: unknown) => err);
    expect(busy).toBeInstanceOf(ControllerBusyError);
    expect(busy).toBeInstanceOf(NoAnswerError); // code that handles silence still handles it
    expect((busy as Error).message).toMatch(/busy writing its settings \(EEPROM\).*longer busy window than 30 ms/);
    const silent = await bus.request(ping(4)).catch((err: unknown) => err);
    expect(silent).toBeInstanceOf(NoAnswerError);
    expect(silent).not.toBeInstanceOf(ControllerBusyError);
  });
});
