// The late/stale-answer rule (docs/protocol.md, Stale answers), with its parameter from the
// generated spec data (spec/host.json timing.late_answer_s -> HOST_TIMING.lateAnswerMs).
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { NoAnswerError } from "../src/bus/errors.js";
import { decode, encode, type Message, make } from "../src/codec.js";
import { HOST_TIMING } from "../src/generated/host.js";
import { FakePort } from "./fake-port.js";

const feedback = (id: number, position: number): Message =>
  make("position_feedback", id, { direction: 1, position, speed: 0, current: 0 });
const fast = { timing: { latencyMs: 2, assumedResponseTimeUs: 100 }, retries: 0 };

describe("stale answers", () => {
  it("takes its late-answer allowance from spec/host.json", () => {
    expect(HOST_TIMING.lateAnswerMs).toBe(100);
    expect(new Bus(new FakePort()).lateAnswerMs).toBe(HOST_TIMING.lateAnswerMs);
  });

  it("never returns a late answer to an earlier request as the answer to the next one", async () => {
    // ID 1 answers the first request late (after its deadline), the second one on time
    let asked = 0;
    const port = new FakePort();
    port.responder = (written) => {
      const request = decode(written);
      asked += 1;
      const answer = encode(feedback(request.id, asked === 1 ? 111 : 222));
      setTimeout(() => port.inject(answer), asked === 1 ? 30 : 1);
      return null;
    };
    const bus = new Bus(port, fast);
    await expect(bus.request(make("request_position", 1, {}))).rejects.toBeInstanceOf(NoAnswerError);
    expect(bus.owedAnswers(1)?.count).toBe(1);
    const second = await bus.request(make("request_position", 1, {}));
    expect(second.position).toBe(222); // not 111, the answer to the first request
    expect(bus.stats.staleFrames).toBe(1);
    expect(bus.stats.quietWaits).toBe(1);
    expect(bus.owedAnswers(1)).toBeUndefined();
  });

  it("ends the quiet period as soon as the owed answer comes", async () => {
    let asked = 0;
    const port = new FakePort();
    port.responder = (written) => {
      asked += 1;
      const answer = encode(feedback(decode(written).id, asked));
      setTimeout(() => port.inject(answer), asked === 1 ? 20 : 1);
      return null;
    };
    const bus = new Bus(port, { ...fast, lateAnswerMs: 5000 });
    await expect(bus.request(make("request_position", 1, {}))).rejects.toBeInstanceOf(NoAnswerError);
    const started = performance.now();
    expect((await bus.request(make("request_position", 1, {}))).position).toBe(2);
    expect(performance.now() - started).toBeLessThan(2000); // did not sit out the 5 s allowance
  });

  it("waits out a lost answer for at most deadline + late, and only for that ID", async () => {
    let silent = true;
    const port = new FakePort((written) => (silent ? null : encode(feedback(decode(written).id, 7))));
    const bus = new Bus(port, { ...fast, lateAnswerMs: 40 });
    await expect(bus.request(make("request_position", 1, {}))).rejects.toBeInstanceOf(NoAnswerError);
    silent = false;
    expect((await bus.request(make("request_position", 2, {}))).position).toBe(7);
    expect(bus.stats.quietWaits).toBe(0); // another ID never waits
    const owed = bus.owedAnswers(1);
    expect(owed).toBeDefined();
    expect((await bus.request(make("request_position", 1, {}))).position).toBe(7);
    expect(bus.stats.quietWaits).toBe(1);
    expect(bus.owedAnswers(1)).toBeUndefined();
  });

  it("takes a late answer to an earlier attempt of the same call as that call's answer", async () => {
    let asked = 0;
    const port = new FakePort();
    port.responder = (written) => {
      asked += 1;
      if (asked === 1) {
        const answer = encode(feedback(decode(written).id, 5));
        setTimeout(() => port.inject(answer), 12); // after attempt 1's deadline, during attempt 2
      }
      return null;
    };
    const bus = new Bus(port, { timing: { latencyMs: 2, assumedResponseTimeUs: 100 }, retries: 3, retryPauseMs: 1 });
    expect((await bus.request(make("request_position", 3, {}))).position).toBe(5);
    expect(asked).toBeGreaterThan(1);
  });

  it("forgets what is owed when the rate changes", async () => {
    const port = new FakePort(() => null);
    const bus = new Bus(port, fast);
    await expect(bus.request(make("request_position", 1, {}))).rejects.toBeInstanceOf(NoAnswerError);
    expect(bus.owedAnswers(1)).toBeDefined();
    await bus.setBaudRate(57600);
    expect(bus.owedAnswers(1)).toBeUndefined();
  });
});
