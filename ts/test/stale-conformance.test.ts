// Runs the language-neutral cases of stale-answers.json (docs/protocol.md, Stale answers) against
// the TypeScript client, with the late allowance from the generated spec data unless a case sets it.
import { readFileSync } from "node:fs";
import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { decode, encode, make } from "../src/codec.js";
import { HOST_TIMING } from "../src/generated/host.js";
import { FakePort } from "./fake-port.js";

interface Answer {
  attempt: number;
  at: { D?: number; L?: number };
  position: number;
}
interface Call {
  id: number;
  answers: Answer[];
  expect: { error?: string; position?: number };
  within_ms?: number;
}
interface Case {
  name: string;
  retries: number;
  late_answer_ms?: number;
  calls: Call[];
}

const cases: Case[] = JSON.parse(readFileSync(new URL("./stale-answers.json", import.meta.url), "utf8")).cases;

describe("stale answers: the shared cases", () => {
  for (const c of cases) {
    it(c.name, async () => {
      const port = new FakePort();
      const bus = new Bus(port, {
        timing: { latencyMs: 2, assumedResponseTimeUs: 100 },
        retries: c.retries,
        retryPauseMs: 1,
        lateAnswerMs: c.late_answer_ms ?? HOST_TIMING.lateAnswerMs,
      });
      let current: { call: Call; attempts: number } | null = null;
      port.responder = (written) => {
        const request = decode(written);
        if (current === null) return null;
        const attempt = current.attempts++;
        const deadline = bus.timeoutMs(request);
        for (const answer of current.call.answers.filter((a) => a.attempt === attempt)) {
          const delay = (answer.at.D ?? 0) * deadline + (answer.at.L ?? 0) * bus.lateAnswerMs;
          const frame = encode(
            make("position_feedback", request.id, { direction: 0, position: answer.position, speed: 0, current: 0 }),
          );
          setTimeout(() => port.inject(frame), delay);
        }
        return null;
      };
      for (const call of c.calls) {
        current = { call, attempts: 0 };
        const started = performance.now();
        const outcome = await bus.request(make("request_position", call.id, {})).then(
          (answer) => ({ position: answer.position }),
          (error: Error) => ({ error: error.name }),
        );
        expect(outcome).toEqual(call.expect);
        if (call.within_ms !== undefined) expect(performance.now() - started).toBeLessThan(call.within_ms);
      }
    });
  }
});
