import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { type PortEvent, PortLost, ReconnectingPort } from "../src/bus/reconnect.js";
import { decode, encode, make } from "../src/codec.js";
import { toHex } from "../src/frame.js";
import { FakePort } from "./fake-port.js";

const answering = (written: Uint8Array): Uint8Array | null => {
  const request = decode(written);
  return request.name === "request_position"
    ? encode(make("position_feedback", request.id, { direction: 1, position: 100, speed: 0, current: 0 }))
    : null;
};

/** Opens a new FakePort each time, or fails while `gone` is set. */
function adapter() {
  const state = { gone: false, opened: [] as FakePort[], attempts: 0 };
  const open = (rate: number): Promise<FakePort> => {
    state.attempts += 1;
    if (state.gone) return Promise.reject(new Error("no such file or directory"));
    const port = new FakePort(answering, rate);
    state.opened.push(port);
    return Promise.resolve(port);
  };
  return { state, open };
}

const until = async (test: () => boolean, ms = 2000): Promise<void> => {
  const end = performance.now() + ms;
  while (!test()) {
    if (performance.now() > end) throw new Error("timed out");
    await new Promise((resolve) => setTimeout(resolve, 5));
  }
};

describe("reconnecting port", () => {
  it("fails fast while lost, reports once, reopens with backoff and sends owed frames first", async () => {
    const { state, open } = adapter();
    const port = await new ReconnectingPort(open, 115200, { name: "/dev/serial/by-id/x" }).start();
    const events: PortEvent[] = [];
    port.onPortEvent((event) => events.push(event));
    const bus = new Bus(port, { timing: { latencyMs: 5, assumedResponseTimeUs: 100 } });
    expect((await bus.request(make("request_position", 1, {}))).id).toBe(1);

    state.gone = true;
    state.opened[0]?.fail(new Error("Input/output error"));
    for (let i = 0; i < 5; i++) {
      await expect(bus.request(make("request_position", 1, {}))).rejects.toBeInstanceOf(PortLost);
    }
    expect(events.map((e) => e.kind)).toEqual(["lost"]);
    const stop = encode(make("set_control", 255, { control: 1 }));
    port.onReturn("estop", stop);
    await new Promise((resolve) => setTimeout(resolve, 400));
    expect(state.attempts - 1).toBeLessThanOrEqual(8); // 50, 100, 100, 100 ms: not a busy loop
    expect(state.attempts - 1).toBeGreaterThanOrEqual(2);

    state.gone = false;
    await until(() => port.up);
    expect(events.map((e) => e.kind)).toEqual(["lost", "back"]);
    expect(events[1]?.sentFirst).toEqual(["estop"]);
    expect((await bus.request(make("request_position", 1, {}))).id).toBe(1); // the bus goes on
    const fresh = state.opened[1];
    expect(fresh?.writes.map(toHex)[0]).toBe(toHex(stop)); // the stop first, then the request
    expect(fresh?.writes.length).toBe(2);
    await port.close();
  });
});
