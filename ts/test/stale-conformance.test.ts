// Runs the shared stale-answer cases (spec/vectors/stale-answers.json; docs/protocol.md, Stale
// answers) against the TypeScript client, as python/tests/client/test_stale_shared.py runs them
// against the Python one: scripted exchanges on a virtual clock (setTimeout and the bus's clock
// move only when the script says), with the late allowance from the generated spec data.
import { readFileSync } from "node:fs";
import { afterEach, describe, expect, it, vi } from "vitest";
import { Bus } from "../src/bus/client.js";
import { wireTimeMs } from "../src/bus/timing.js";
import { answerName, decode, encode, type Message, make, messageSpec } from "../src/codec.js";
import { HOST_TIMING } from "../src/generated/host.js";
import { FakePort } from "./fake-port.js";
import { settle, VirtualClock } from "./virtual-clock.js";

interface WireEntry {
  frame: number;
  at: { ms?: number; D?: number; L?: number; chars?: number };
  answer?: Record<string, number>;
  message?: { name: string; id?: number } & Record<string, number | string>;
  part?: [number, number?];
}
interface Step {
  ask?: { request: string; id: number };
  ask_all?: { request: string; ids: number[]; slot: number };
  wire: WireEntry[];
  sends: string[];
  expect: Record<string, unknown>;
  min_elapsed?: { D?: number; L?: number };
  max_elapsed?: { ms: number };
  owed_after?: Record<string, number>;
}
interface Case {
  name: string;
  retries: number;
  steps: Step[];
  stats: Record<string, number>;
}
interface Shared {
  timing: { baud: number; latency_ms: number; margin_ms: number; response_time_us: number };
  cases: Case[];
}

const shared: Shared = JSON.parse(
  readFileSync(new URL("../../spec/vectors/stale-answers.json", import.meta.url), "utf8"),
);

function frame(name: string, id: number, given: Record<string, number>): Uint8Array {
  const fields = Object.fromEntries(messageSpec(name).fields.map((f) => [f.name, given[f.name] ?? 0]));
  return encode(make(name, id, fields));
}

function outcome(result: Message | Error): Record<string, unknown> {
  if (result instanceof Error) return { error: result.name.replace(/Error$/, "") };
  if (result.name === "position_feedback") return { position: (result as unknown as { position: number }).position };
  return { name: result.name };
}

/** The window of a broadcast read of `count` staggered IDs (as nurimc.procedures.group.broadcast_window). */
function broadcastWindowMs(count: number, slot: number): number {
  const { baud, latency_ms, margin_ms } = shared.timing;
  return (count + 1) * slot * 0.1 + wireTimeMs(18, baud) + 2 * latency_ms + margin_ms;
}

const statNames: Record<string, "staleFrames" | "fences" | "quietWaits" | "echoes"> = {
  echo_frames: "echoes",
  stale_frames: "staleFrames",
  fences: "fences",
  quiet_waits: "quietWaits",
};

describe("stale answers: the shared cases (spec/vectors/stale-answers.json)", () => {
  afterEach(() => {
    vi.unstubAllGlobals();
  });

  it("takes its late allowance from the generated spec data", () => {
    expect(new Bus(new FakePort()).lateAnswerMs).toBe(HOST_TIMING.lateAnswerMs);
  });

  for (const c of shared.cases) {
    it(c.name, async () => {
      const clock = new VirtualClock();
      vi.stubGlobal("setTimeout", clock.setTimeout);
      vi.stubGlobal("clearTimeout", clock.clearTimeout);
      const port = new FakePort(() => null, shared.timing.baud);
      const bus = new Bus(port, {
        timing: {
          latencyMs: shared.timing.latency_ms,
          marginMs: shared.timing.margin_ms,
          assumedResponseTimeUs: shared.timing.response_time_us,
        },
        retries: c.retries,
        now: () => clock.now,
      });
      let script: WireEntry[] = [];
      let sent: Message[] = [];
      port.responder = (written) => {
        const request = decode(written);
        const index = sent.length;
        sent.push(request);
        for (const entry of script.filter((e) => e.frame === index)) {
          const delay =
            (entry.at.ms ?? 0) +
            (entry.at.D === undefined ? 0 : entry.at.D * bus.timeoutMs(request)) +
            (entry.at.L ?? 0) * bus.lateAnswerMs +
            (entry.at.chars ?? 0) * wireTimeMs(1, port.baudRate);
          let bytes: Uint8Array;
          if (entry.message !== undefined) {
            const { name, id, ...fields } = entry.message;
            bytes = frame(name, id ?? request.id, fields as Record<string, number>);
          } else bytes = frame(answerName(request.name), request.id, entry.answer ?? {});
          if (entry.part !== undefined) bytes = bytes.slice(entry.part[0], entry.part[1]);
          clock.setTimeout(() => port.inject(bytes), delay); // the write takes no time here
        }
        return null;
      };
      for (const [number, step] of c.steps.entries()) {
        script = step.wire;
        sent = [];
        const started = clock.now;
        let result: Record<string, unknown> | undefined;
        const { ask, ask_all: all } = step;
        const call =
          ask !== undefined
            ? bus.request(make(ask.request, ask.id, {})).then(outcome)
            : all !== undefined
              ? bus
                  .requestBroadcast(all.request, all.ids, { windowMs: broadcastWindowMs(all.ids.length, all.slot) })
                  .then((got) => Object.fromEntries([...got].map(([id, answer]) => [String(id), outcome(answer)])))
              : Promise.reject(new Error(`step ${number}: neither ask nor ask_all`));
        call.then(
          (got) => {
            result = got;
          },
          (error: Error) => {
            result = outcome(error);
          },
        );
        await settle();
        while (result === undefined) {
          if (!clock.step()) throw new Error(`step ${number}: the call waits for nothing (it would hang)`);
          await settle();
        }
        expect(
          sent.map((m) => `${m.name} ${m.id}`),
          `step ${number}: frames sent`,
        ).toEqual(step.sends);
        expect(result, `step ${number}`).toEqual(step.expect);
        if (step.max_elapsed !== undefined) expect(clock.now - started).toBeLessThanOrEqual(step.max_elapsed.ms);
        if (step.min_elapsed !== undefined && ask !== undefined) {
          const least =
            (step.min_elapsed.D ?? 0) * bus.timeoutMs(make(ask.request, ask.id, {})) +
            (step.min_elapsed.L ?? 0) * bus.lateAnswerMs;
          expect(clock.now - started, `step ${number}: time taken`).toBeGreaterThanOrEqual(least);
        }
        for (const [id, count] of Object.entries(step.owed_after ?? {}))
          expect(bus.owedAnswers(Number(id))?.count ?? 0, `step ${number}: ID ${id} owes`).toBe(count);
      }
      const stats = Object.fromEntries(
        Object.keys(c.stats).map((k) => {
          const name = statNames[k];
          if (name === undefined) throw new Error(`unknown stat ${k} in the shared cases`);
          return [k, bus.stats[name]];
        }),
      );
      expect(stats).toEqual(c.stats);
    });
  }
});
