import { readFileSync } from "node:fs";
import { describe, expect, it } from "vitest";
import { stepFigures } from "../src/stepfigures.js";

interface Case {
  name: string;
  times: number[];
  positions: number[];
  start: number;
  target: number;
  error?: boolean;
  expect?: { rise: number | null; overshoot: number; settling: number | null; final_error: number; settled: boolean };
}

const cases = (
  JSON.parse(readFileSync(new URL("../../spec/vectors/step-figures.json", import.meta.url), "utf8")) as {
    cases: Case[];
  }
).cases;

const near = (mine: number | null, theirs: number | null, tolerance: number): void => {
  expect(mine === null).toBe(theirs === null);
  if (mine !== null && theirs !== null) expect(Math.abs(mine - theirs)).toBeLessThanOrEqual(tolerance);
};

describe("step figures: the shared vectors (spec/vectors/step-figures.json)", () => {
  it("has cases", () => expect(cases.length).toBeGreaterThan(5));
  for (const c of cases) {
    it(c.name, () => {
      if (c.error) {
        expect(() => stepFigures(c.times, c.positions, c.start, c.target)).toThrow(RangeError);
        return;
      }
      const f = stepFigures(c.times, c.positions, c.start, c.target);
      const e = c.expect as NonNullable<Case["expect"]>;
      near(f.rise, e.rise, 1e-9);
      near(f.settling, e.settling, 1e-9);
      near(f.overshoot, e.overshoot, 0.005);
      near(f.finalError, e.final_error, 0.0005);
      expect(f.settled).toBe(e.settled);
    });
  }
});
