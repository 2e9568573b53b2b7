import { execFileSync } from "node:child_process";
import { fileURLToPath } from "node:url";
import fc from "fast-check";
import { describe, expect, it } from "vitest";
import { SPECS } from "../src/generated/tables.js";
import { describeRange, fromWire, toWire } from "../src/units.js";

const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const SCALES = [0.01, 0.1, 1, 100];

describe("units", () => {
  it("rounds to the nearest step, halves away from zero, in decimal", () => {
    expect(toWire(180.005, 0.01)).toBe(18001); // 180.005 is 180.00499999... in binary
    expect(toWire(0.15, 0.1)).toBe(2);
    expect(toWire(-0.15, 0.1)).toBe(-2);
    expect(toWire(0.14999, 0.1)).toBe(1);
    expect(toWire(250, 100)).toBe(3);
    expect(toWire(249.99, 100)).toBe(2);
    expect(toWire(1e-7, 0.01)).toBe(0);
    expect(toWire(1.5e21, 0.1)).toBe(1.5e22);
  });

  it("converts wire to physical exactly to the step's decimals", () => {
    expect(fromWire(3, 0.1)).toBe(0.3);
    expect(fromWire(18001, 0.01)).toBe(180.01);
    expect(fromWire(65533, 0.01)).toBe(655.33);
    expect(fromWire(2, 100)).toBe(200);
  });

  it("round-trips every wire integer through its physical value", () => {
    fc.assert(
      fc.property(fc.integer({ min: 0, max: 65535 }), fc.constantFrom(...SCALES), (raw, scale) => {
        expect(toWire(fromWire(raw, scale), scale)).toBe(raw);
      }),
      { numRuns: 5000 },
    );
  });

  it("refuses values that are not finite numbers", () => {
    expect(() => toWire(NaN, 0.1)).toThrow(/not a finite number/);
    expect(() => toWire(Infinity, 0.1)).toThrow(/not a finite number/);
  });

  it("describes ranges with their physical units", () => {
    const speed = SPECS.position_speed.fields[2]!;
    expect(describeRange(speed)).toBe("1..65533 (0.1..6553.3 rpm)");
    expect(describeRange(SPECS.position_speed.fields[0]!)).toBe("0..1 (0 ccw, 1 cw)");
  });

  it("agrees with the Python library on random values (one Python process)", () => {
    const values = fc.sample(
      fc.oneof(
        fc.double({ min: -1000, max: 1000, noNaN: true }),
        fc.integer({ min: -100000, max: 100000 }).map((n) => n / 1000),
        fc.integer({ min: -100000, max: 100000 }).map((n) => n / 200),
      ),
      { numRuns: 600, seed: 7 },
    );
    const cases = values.flatMap((v) => SCALES.map((s) => [v, s] as const));
    const script =
      "import json,sys\nfrom nurimc.protocol.units import to_wire\nprint(json.dumps([to_wire(v, s) for v, s in json.load(sys.stdin)]))";
    const python = execFileSync("python3", ["-c", script], {
      input: JSON.stringify(cases),
      env: { ...process.env, PYTHONPATH: `${ROOT}python/src` },
    });
    const expected = JSON.parse(python.toString()) as number[];
    expect(cases.map(([v, s]) => toWire(v, s))).toEqual(expected);
  });
});
