// The emergency stop and the stale-answer rule (docs/protocol.md, Stale answers): a stop never
// waits behind a fence, and the read-back after it is fenced like any other request. On a virtual
// clock that never moves here: whatever the stop needed to wait for, it would never finish.
import { afterEach, describe, expect, it, vi } from "vitest";
import { Bus } from "../src/bus/client.js";
import { CancelledError, NoAnswerError } from "../src/bus/errors.js";
import { decode, encode, make } from "../src/codec.js";
import { FakePort } from "./fake-port.js";
import { settle, VirtualClock } from "./virtual-clock.js";

const names = (port: FakePort): string[] => port.writes.map((w) => `${decode(w).name} ${decode(w).id}`);

describe("emergency stop and fences", () => {
  afterEach(() => {
    vi.unstubAllGlobals();
  });

  it("goes out while a request waits behind a fence; the read-back after it is fenced too", async () => {
    const clock = new VirtualClock();
    vi.stubGlobal("setTimeout", clock.setTimeout);
    vi.stubGlobal("clearTimeout", clock.clearTimeout);
    const port = new FakePort(() => null);
    const bus = new Bus(port, {
      timing: { latencyMs: 2, assumedResponseTimeUs: 100 },
      retries: 0,
      now: () => clock.now,
    });

    // a lost answer: ID 1 owes a position answer
    let lost: unknown;
    bus.request(make("request_position", 1, {})).catch((e) => {
      lost = e;
    });
    await settle();
    while (lost === undefined && clock.step()) await settle();
    expect(lost).toBeInstanceOf(NoAnswerError);
    expect(bus.owedAnswers(1)?.count).toBe(1);

    // the next request to ID 1 sends a fence and waits for its answer...
    let fenced: unknown;
    bus.request(make("request_position", 1, {})).catch((e) => {
      fenced = e;
    });
    await settle();
    expect(names(port)).toEqual(["request_position 1", "request_ping 1"]);

    // ...and the stop goes out now, with the clock standing still: it waits for no fence
    let stopped = false;
    const stop = bus.emergency(make("set_control", 255, { control: 1 })).then(() => {
      stopped = true;
    });
    for (let i = 0; i < 5 && !stopped; i++) await settle();
    expect(stopped).toBe(true);
    await stop;
    expect(fenced).toBeInstanceOf(CancelledError);
    expect(names(port).at(-1)).toBe("set_control 255");

    // the read-back is a request like any other: ID 1 still owes, so a fence goes first, and the
    // late answer that arrives then is not taken for the read-back
    port.responder = (written) => {
      const request = decode(written);
      if (request.name === "request_ping") {
        const late = encode(make("position_feedback", 1, { direction: 0, position: 111, speed: 0, current: 0 }));
        const ping = encode(make("ping", 1, {}));
        clock.setTimeout(() => port.inject(late), 1);
        clock.setTimeout(() => port.inject(ping), 2);
      } else if (request.name === "request_position") {
        const fresh = encode(make("position_feedback", 1, { direction: 0, position: 222, speed: 0, current: 0 }));
        clock.setTimeout(() => port.inject(fresh), 3);
      }
      return null;
    };
    let readBack: { position: number } | undefined;
    bus.request(make("request_position", 1, {})).then((answer) => {
      readBack = answer;
    });
    await settle();
    while (readBack === undefined && clock.step()) await settle();
    expect(readBack?.position).toBe(222);
    expect(names(port).slice(-2)).toEqual(["request_ping 1", "request_position 1"]);
    expect(bus.stats.fences).toBe(2);
  });
});
