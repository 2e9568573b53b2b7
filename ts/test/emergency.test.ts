// The emergency stop jumps the queue (docs/dashboard.md, Direct mode).
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { CancelledError } from "../src/bus/errors.js";
import { decode, encode, make } from "../src/codec.js";
import { FakePort } from "./fake-port.js";

describe("emergency stop", () => {
  it("cancels everything queued and writes the stop next, not after the queue", async () => {
    const port = new FakePort((written) => {
      const request = decode(written);
      return request.name === "request_position"
        ? encode(make("position_feedback", request.id, { direction: 1, position: 0, speed: 0, current: 0 }))
        : null;
    });
    const bus = new Bus(port, { timing: { latencyMs: 1, assumedResponseTimeUs: 100 } });
    const moves = Array.from({ length: 300 }, (_, n) =>
      bus.send(make("position_speed", 1 + (n % 3), { direction: 0, position: n * 10, speed: 100 })),
    );
    const poll = bus.request(make("request_position", 1, {}));
    const stop = bus.emergency(make("set_control", 255, { control: 1 }));
    const after = bus.request(make("request_control", 2, {}), { retries: 0 }).catch((e) => e);
    await stop;
    const results = await Promise.allSettled([...moves, poll]);
    // nothing queued had reached the port yet: the stop is the first frame, no move follows it
    expect(port.writes.map((w) => decode(w).name).slice(0, 1)).toEqual(["set_control"]);
    expect(port.writes.filter((w) => decode(w).name === "position_speed")).toEqual([]);
    const cancelled = results.filter((r) => r.status === "rejected" && r.reason instanceof CancelledError);
    expect(cancelled.length).toBe(301);
    expect(bus.stats.cancelled).toBe(301);
    await after; // a call made after the stop still runs (after it)
    expect(port.writes.map((w) => decode(w).name).at(-1)).toBe("request_control");
  });

  it("goes right after the call already on the wire", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, { timing: { latencyMs: 1, assumedResponseTimeUs: 100 } });
    const first = bus.send(make("position_speed", 1, { direction: 0, position: 10, speed: 100 }));
    await first; // on the wire
    const queued = Array.from({ length: 50 }, () =>
      bus.send(make("position_speed", 2, { direction: 0, position: 10, speed: 100 })).catch((e) => e),
    );
    await bus.emergency(make("set_control", 255, { control: 1 }));
    expect((await Promise.all(queued)).every((e) => e instanceof CancelledError)).toBe(true);
    expect(port.writes.map((w) => decode(w).name)).toEqual(["position_speed", "set_control"]);
  });

  it("stops waiting for the answer of the call in progress", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, { timing: { latencyMs: 1000, assumedResponseTimeUs: 100 } }); // a long deadline
    const waiting = bus.request(make("request_position", 1, {}));
    await new Promise((r) => setTimeout(r, 5));
    const started = performance.now();
    await bus.emergency(make("set_control", 255, { control: 1 }));
    await expect(waiting).rejects.toBeInstanceOf(CancelledError);
    expect(performance.now() - started).toBeLessThan(500);
    expect(decode(port.writes.at(-1) as Uint8Array)).toMatchObject({ name: "set_control", id: 255 });
  });

  it("refuses a request as an emergency frame", async () => {
    const bus = new Bus(new FakePort());
    await expect(bus.emergency(make("request_position", 1, {}))).rejects.toThrow(/not a command/);
  });
});
