// The stale-answer rule (docs/protocol.md, Stale answers), with its parameter from the generated
// spec data (spec/host.json timing.late_answer_s -> HOST_TIMING.lateAnswerMs). The rule's cases are
// language-neutral in spec/vectors/stale-answers.json (stale-conformance.test.ts runs them).
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { NoAnswerError } from "../src/bus/errors.js";
import { make } from "../src/codec.js";
import { HOST_TIMING } from "../src/generated/host.js";
import { FakePort } from "./fake-port.js";

const fast = { timing: { latencyMs: 2, assumedResponseTimeUs: 100 }, retries: 0 };

describe("stale answers", () => {
  it("takes its late-answer allowance from spec/host.json", () => {
    expect(HOST_TIMING.lateAnswerMs).toBeGreaterThan(0);
    expect(new Bus(new FakePort()).lateAnswerMs).toBe(HOST_TIMING.lateAnswerMs);
  });

  it("refuses a broadcast read that cannot be told apart", async () => {
    const bus = new Bus(new FakePort(), fast);
    await expect(bus.requestBroadcast("request_position", [1, 255])).rejects.toThrow(/0\.\.254/);
    await expect(bus.requestBroadcast("request_position", [1, 1])).rejects.toThrow(/listed twice/);
    await expect(bus.requestBroadcast("set_control", [1])).rejects.toThrow(/not a request/);
    await expect(bus.requestBroadcast("request_position", [1], { windowMs: -1 })).rejects.toThrow(/>= 0/);
    expect(await bus.requestBroadcast("request_position", [])).toEqual(new Map());
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
