/** The driver contract as the TypeScript client keeps it (docs/drivers.md, "The TypeScript client"). */
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { BusClosedError, NoAnswerError } from "../src/bus/errors.js";
import { decode, encode, make } from "../src/codec.js";
import { FakePort } from "./fake-port.js";

const ping = (id: number) => make("request_ping", id, {});
const pingsFrom = (ids: number[]) => (written: Uint8Array) => {
  const request = decode(written);
  return ids.includes(request.id) && request.name === "request_ping" ? encode(make("ping", request.id, {})) : null;
};
const slow = { timing: { latencyMs: 200, assumedResponseTimeUs: 100 }, retries: 0 }; // long deadlines

describe("driver contract (TypeScript client)", () => {
  it("fails a call waiting for its answer as soon as the port fails, not at its timeout", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, slow);
    const call = bus.request(ping(1));
    setTimeout(() => port.fail(new Error("device unplugged")), 5);
    const error = await call.catch((e: unknown) => e);
    expect(error).toBeInstanceOf(BusClosedError); // not NoAnswerError: it did not wait for its deadline
    expect((error as Error).message).toMatch(/device unplugged/);
    expect(((error as Error).cause as Error).message).toBe("device unplugged");
    await expect(bus.request(ping(1))).rejects.toBeInstanceOf(BusClosedError);
  });

  it("an abort while waiting for the answer rejects with the reason and frees the queue", async () => {
    const port = new FakePort(pingsFrom([2]));
    const bus = new Bus(port, slow);
    const controller = new AbortController();
    const call = bus.request(ping(1), { signal: controller.signal });
    const next = bus.request(ping(2));
    setTimeout(() => controller.abort(new Error("operator stop")), 5);
    await expect(call).rejects.toThrow("operator stop");
    expect(await next).toEqual(make("ping", 2, {}));
    expect(port.writes).toHaveLength(2);
  });

  it("a call aborted while queued never touches the port", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, { ...slow, timing: { latencyMs: 1, assumedResponseTimeUs: 100 } });
    const first = bus.request(ping(1)).catch((e: unknown) => e);
    const controller = new AbortController();
    const queued = bus.request(ping(3), { signal: controller.signal });
    controller.abort(new Error("never mind"));
    await expect(queued).rejects.toThrow("never mind");
    expect(await first).toBeInstanceOf(NoAnswerError);
    expect(port.writes.map((w) => decode(w).id)).toEqual([1]);
  });

  it("AbortSignal.timeout ends a busy-window wait: a timeout of the whole call", async () => {
    const port = new FakePort(pingsFrom([4]));
    const bus = new Bus(port, { ...slow, busyWindowMs: 2000 });
    await bus.send(make("set_control", 4, { control: 1 })); // ID 4 is busy for 2 s
    const error = await bus.request(ping(4), { signal: AbortSignal.timeout(20) }).catch((e: unknown) => e);
    expect((error as Error).name).toBe("TimeoutError");
    expect(port.writes).toHaveLength(1); // the request was never written into the busy window
    expect(await bus.request(ping(5), { retries: 0 }).catch((e: unknown) => e)).toBeInstanceOf(NoAnswerError);
  });
});
