import { describe, expect, it, vi } from "vitest";
import { Bus } from "../src/bus/client.js";
import {
  BusClosedError,
  BusError,
  CorruptedAnswerError,
  NoAnswerError,
  UnexpectedAnswerError,
} from "../src/bus/errors.js";
import { type BytePort, Listeners, receive } from "../src/bus/port.js";
import { answerDeadlineMs, wireTimeMs } from "../src/bus/timing.js";
import { decode, encode, type Message, make } from "../src/codec.js";
import { FieldRangeError } from "../src/errors.js";
import { toHex } from "../src/frame.js";
import { concat, FakePort } from "./fake-port.js";

const feedback = (id: number, position = 18000): Message =>
  make("position_feedback", id, { direction: 1, position, speed: 25, current: 3 });

/** A controller at each of `ids` that answers position requests and pings. */
function answering(ids: number[]) {
  return (written: Uint8Array): Uint8Array | null => {
    const request = decode(written);
    if (!ids.includes(request.id)) return null;
    if (request.name === "request_position") return encode(feedback(request.id));
    if (request.name === "request_ping") return encode(make("ping", request.id, {}));
    return null;
  };
}

const fast = { timing: { latencyMs: 5, assumedResponseTimeUs: 100 } }; // short timeouts for silence tests; answers come within a few ms

describe("bus client", () => {
  it("returns the answer that matches the request's ID and answer mode", async () => {
    const port = new FakePort(answering([4]));
    const bus = new Bus(port, fast);
    const answer = await bus.request(make("request_position", 4, {}));
    expect(answer).toEqual(feedback(4));
    expect(answer.position).toBe(18000); // typed: the answer of request_position is position_feedback
    expect(port.writes.map(toHex)).toEqual(["fffe040258a1"]);
  });

  it("skips the adapter's echo, noise and other IDs' frames before the answer", async () => {
    const port = new FakePort((w) => [w, new Uint8Array([0x00, 0xff, 0x13]), encode(feedback(9)), encode(feedback(4))]);
    const bus = new Bus(port, fast);
    expect(await bus.request(make("request_position", 4, {}))).toEqual(feedback(4));
    expect(bus.stats).toMatchObject({ echoes: 1, unexpectedFrames: 1, retries: 0 });
  });

  it("asks the same ID again two characters after its answer, on the host's clock, not after a timer's 1 ms", async () => {
    // a line that answers at once: each request after the first would come within two characters
    const line = new Listeners<Uint8Array>();
    const written: number[] = [];
    const answered: number[] = [];
    const port: BytePort = {
      baudRate: 38400, // two characters: 0.52 ms, under the 1 ms a timer waits at least
      write(data) {
        written.push(performance.now());
        line.emit(encode(feedback(decode(data).id)));
        answered.push(performance.now());
        return Promise.resolve();
      },
      onData: (listener) => line.add(listener),
      onError: () => () => undefined,
      setBaudRate: () => Promise.resolve(),
      close: () => Promise.resolve(),
    };
    const delays: number[] = [];
    const realSetTimeout = globalThis.setTimeout;
    vi.stubGlobal("setTimeout", (run: () => void, ms?: number) => {
      delays.push(ms ?? 0);
      return realSetTimeout(run, ms);
    });
    try {
      const bus = new Bus(port, fast);
      for (let i = 0; i < 5; i++) expect((await bus.request(make("request_position", 3, {}))).position).toBe(18000);
    } finally {
      vi.unstubAllGlobals();
    }
    const gap = 2 * wireTimeMs(1, 38400);
    for (let i = 1; i < written.length; i++) expect(written[i]! - answered[i - 1]!).toBeGreaterThanOrEqual(gap - 0.001); // performance.now's rounding
    // no sub-millisecond timer: Node would wait 1 ms for it (twice the gap)
    expect(delays.filter((ms) => ms > 0 && ms < 1)).toEqual([]);
  });

  it("discards stale bytes that arrived before the request", async () => {
    const port = new FakePort(answering([2]));
    const bus = new Bus(port, fast);
    port.inject(encode(feedback(2, 1))); // a late answer to some earlier request
    port.inject(encode(feedback(2, 2)).subarray(0, 5)); // and half of another
    expect((await bus.request(make("request_position", 2, {}))).position).toBe(18000);
    expect(bus.stats.staleFrames).toBe(1);
  });

  it("retries a request that got no answer, then succeeds", async () => {
    let calls = 0;
    const port = new FakePort((w) => (++calls === 1 ? null : answering([1])(w)));
    const bus = new Bus(port, fast);
    expect(await bus.request(make("request_ping", 1, {}))).toEqual(make("ping", 1, {}));
    expect(port.writes).toHaveLength(2);
    expect(bus.stats.retries).toBe(1);
  });

  it("gives up after the retries with NoAnswerError naming the likely causes", async () => {
    const port = new FakePort(() => null, 9600);
    const bus = new Bus(port, { ...fast, retries: 1 });
    const failure = bus.request(make("request_ping", 7, {}));
    await expect(failure).rejects.toBeInstanceOf(NoAnswerError);
    await expect(failure).rejects.toThrow(
      /no answer to request_ping to ID 7 after 2 attempt\(s\).*9600 bps.*wrong|not at 9600 bps/,
    );
    expect(port.writes).toHaveLength(2);
    expect(bus.stats.noAnswer).toBe(1);
  });

  it("reports garbage instead of an answer as a corrupted answer", async () => {
    const garbled = encode(feedback(3));
    garbled[8] = garbled[8]! ^ 0x10; // a flipped bit: the checksum no longer fits
    const port = new FakePort(() => garbled);
    const bus = new Bus(port, { ...fast, retries: 0 });
    const failure = bus.request(make("request_position", 3, {}));
    await expect(failure).rejects.toBeInstanceOf(CorruptedAnswerError);
    await expect(failure).rejects.toThrow(/1 bad checksum/);
  });

  it("reports a valid frame that is not the answer as unexpected", async () => {
    const port = new FakePort(() => encode(make("ping", 3, {})));
    const bus = new Bus(port, { ...fast, retries: 0 });
    await expect(bus.request(make("request_position", 3, {}))).rejects.toBeInstanceOf(UnexpectedAnswerError);
  });

  it("sends commands once without waiting, and never repeats one (a relative move must not run twice)", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, { timing: { latencyMs: 600_000 } }); // waiting for an answer would time the test out
    await bus.send(make("set_position_mode", 2, { position_mode: 1 })); // an EEPROM write: ID 2 is busy (busy.test.ts), ID 1 is not
    await bus.send(make("position_speed", 1, { direction: 0, position: 9000, speed: 100 }));
    expect(port.writes.map(toHex)).toEqual([
      toHex(encode(make("set_position_mode", 2, { position_mode: 1 }))),
      "fffe010747010023280064",
    ]);
    expect(bus.stats.commands).toBe(2);
  });

  it("sends several commands back to back in one write", async () => {
    const port = new FakePort();
    const bus = new Bus(port, fast);
    await bus.send(make("set_control", 1, { control: 0 }), make("set_control", 2, { control: 0 }));
    expect(port.writes.map(toHex)).toEqual(["fffe0103ef0c00" + "fffe0203ee0c00"]);
    expect(bus.stats.commands).toBe(2);
  });

  it("refuses to send a request as a command, a command as a request, and broadcast requests", async () => {
    const bus = new Bus(new FakePort(), fast);
    await expect(bus.send(make("request_ping", 1, {}))).rejects.toThrow(/not a command; use request\(\)/);
    await expect(bus.request(make("set_control", 1, { control: 1 }))).rejects.toThrow(
      /commands are sent with send\(\)/,
    );
    await expect(bus.request({ name: "request_ping", id: 255 })).rejects.toBeInstanceOf(FieldRangeError);
    await expect(bus.setBaudRate(12345)).rejects.toThrow(/use one of 110, 300/);
  });

  it("serialises concurrent calls: one transaction on the wire at a time", async () => {
    const events: string[] = [];
    const port = new FakePort((w) => {
      events.push(`write ${decode(w).id}`);
      return answering([1, 2])(w);
    });
    const bus = new Bus(port, fast);
    const [a, b] = await Promise.all([
      bus.request(make("request_ping", 1, {})),
      bus.request(make("request_ping", 2, {})).then((m) => (events.push("answer 2"), m)),
    ]);
    expect([a.id, b.id]).toEqual([1, 2]);
    expect(events).toEqual(["write 1", "write 2", "answer 2"]);
  });

  it("computes the timeout from baud rate, frame lengths, response time and adapter latency", () => {
    expect(wireTimeMs(12, 9600)).toBeCloseTo(12.5, 6);
    // the Python library's rule and defaults: wire both ways + response time + 2 x 2 ms latency + 3 ms margin
    expect(answerDeadlineMs(6, 12, 9600, 100)).toBeCloseTo(6.25 + 12.5 + 0.1 + 4 + 3, 6);
    expect(answerDeadlineMs(6, 12, 9600, undefined)).toBeCloseTo(6.25 + 12.5 + 25.4 + 4 + 3, 6); // unknown: the largest setting
    const bus = new Bus(new FakePort(() => null, 110), { timing: { latencyMs: 16 }, responseTimesUs: { 3: 300 } });
    expect(bus.timeoutMs(make("request_position", 3, {}))).toBeCloseTo((18 * 10 * 1000) / 110 + 0.3 + 32 + 3, 6);
    expect(bus.timeoutMs(make("request_position", 4, {}))).toBeCloseTo((18 * 10 * 1000) / 110 + 25.4 + 32 + 3, 6);
    expect(() => new Bus(new FakePort(), { timing: { latencyMs: -1 } })).toThrow(/timing.latencyMs = -1/);
  });

  it("counts the deadline from the end of the write, not its start", async () => {
    const port = new FakePort();
    port.write = async (data) => {
      port.writes.push(data.slice());
      await new Promise((r) => setTimeout(r, 150)); // a slow port: far longer than the ~24 ms deadline
      port.inject(encode(make("ping", 1, {})));
    };
    const bus = new Bus(port, { ...fast, timing: { latencyMs: 10, assumedResponseTimeUs: 100 }, retries: 0 });
    expect(bus.timeoutMs(make("request_ping", 1, {}))).toBeLessThan(50);
    expect(await bus.request(make("request_ping", 1, {}))).toEqual(make("ping", 1, {}));
  });

  it("fails every call after the port fails or the bus is closed", async () => {
    const port = new FakePort(answering([1]));
    const bus = new Bus(port, fast);
    port.fail(new Error("device unplugged"));
    await expect(bus.request(make("request_ping", 1, {}))).rejects.toThrow(/device unplugged/);
    const other = new Bus(new FakePort(answering([1])), fast);
    await other.close();
    await expect(other.send(make("set_control", 1, { control: 1 }))).rejects.toBeInstanceOf(BusClosedError);
    expect(new BusClosedError("x")).toBeInstanceOf(BusError);
  });

  it("reports every frame sent and received to the traffic listener", async () => {
    const seen: string[] = [];
    const bus = new Bus(new FakePort(answering([5])), {
      ...fast,
      onTraffic: (e) => seen.push(`${e.direction} ${e.message.name}`),
    });
    await bus.request(make("request_ping", 5, {}));
    expect(seen).toEqual(["tx request_ping", "rx ping"]);
  });

  it("delivers received bytes as an async iterator too", async () => {
    const port = new FakePort();
    const abort = new AbortController();
    const got: number[] = [];
    const reading = (async () => {
      for await (const chunk of receive(port, abort.signal)) {
        got.push(...chunk);
        if (got.length >= 3) abort.abort();
      }
    })();
    port.inject(new Uint8Array([1, 2]));
    port.inject(concat(new Uint8Array([3])));
    await reading;
    expect(got).toEqual([1, 2, 3]);
    expect(port.listeners).toBe(0);
  });
});

describe("bus client on arbitrary bus bytes", () => {
  it("always settles with the answer or a BusError, never hangs or throws anything else", async () => {
    const fc = (await import("fast-check")).default;
    const answerFrame = encode(make("ping", 6, {}));
    await fc.assert(
      fc.asyncProperty(
        fc.array(fc.uint8Array({ maxLength: 20 }), { maxLength: 4 }),
        fc.boolean(),
        async (junk, withAnswer) => {
          const port = new FakePort(() => (withAnswer ? [...junk, answerFrame] : junk));
          const bus = new Bus(port, {
            timing: { latencyMs: withAnswer ? 100 : 1, assumedResponseTimeUs: 100 },
            retries: 0,
          }); // generous where an answer is due
          try {
            const answer = await bus.request(make("request_ping", 6, {}));
            expect(answer).toEqual(make("ping", 6, {}));
          } catch (err) {
            expect(err).toBeInstanceOf(BusError);
            expect(withAnswer).toBe(false); // a valid answer behind any junk is always found
          }
        },
      ),
      { numRuns: 60 },
    );
  });
});
