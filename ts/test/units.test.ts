import { readFileSync } from "node:fs";
import { fileURLToPath } from "node:url";
import fc from "fast-check";
import { describe, expect, it } from "vitest";
import { SPECS } from "../src/generated/tables.js";
import { SETTINGS, settingFromWire, settingToWire } from "../src/settings.js";
import {
  arrivalToWire,
  describeRange,
  fromWire,
  positionToWire,
  signedFromWire,
  speedToWire,
  toWire,
  UnitRangeError,
} from "../src/units.js";

const SCALES = [0.01, 0.1, 1, 100];

interface Vector {
  name: string;
  input?: Record<string, unknown>;
  line?: [string, number][];
  expect: Record<string, unknown>;
}

/** spec/vectors/units.jsonl: the shared unit vectors (tools/make_vectors.py, from a reference model). */
const VECTORS: Vector[] = readFileSync(
  fileURLToPath(new URL("../../spec/vectors/units.jsonl", import.meta.url)),
  "utf8",
)
  .split("\n")
  .filter((line) => line.trim() !== "")
  .map((line) => JSON.parse(line) as Vector);

/** A vector's request, read the way every JSON reader reads numbers (1e400 is Infinity). */
function requestOf(vector: Vector): Record<string, unknown> {
  if (vector.input !== undefined) return vector.input;
  return JSON.parse((vector.line ?? []).map(([text, times]) => text.repeat(times)).join("")) as Record<string, unknown>;
}

/** The library's own answer to a to_wire request whose value is a number or a value name. */
function libraryToWire(quantity: string, value: number | string): Record<string, unknown> {
  try {
    if (quantity === "degrees") return { ...positionToWire(value as number) };
    if (quantity === "rpm") return { ...speedToWire(value as number) };
    if (quantity === "seconds") return { wire: arrivalToWire(value as number) };
    const spec = SETTINGS.find((s) => s.name === quantity);
    if (spec === undefined) throw new Error(`no quantity ${quantity}`);
    return { wire: settingToWire(spec, value) };
  } catch (err) {
    if (err instanceof UnitRangeError) return { error: "range" };
    throw err;
  }
}

function libraryFromWire(quantity: string, wire: number, direction: number): unknown {
  if (quantity === "degrees") return signedFromWire(direction, wire, 0.01);
  if (quantity === "rpm") return signedFromWire(direction, wire, 0.1);
  if (quantity === "seconds") return fromWire(wire, 0.1);
  const spec = SETTINGS.find((s) => s.name === quantity);
  if (spec === undefined) throw new Error(`no quantity ${quantity}`);
  return settingFromWire(spec, wire);
}

describe("units: the shared vectors (spec/vectors/units.jsonl)", () => {
  // The vectors with a number (or value name) for a known quantity go straight to the library;
  // the others (types, unknown quantities, integer-ness as written) are the conformance
  // program's JSON layer, checked through conformance/run.
  const toWire_ = VECTORS.filter((v) => {
    const r = requestOf(v);
    return (
      r["op"] === "to_wire" &&
      (typeof r["value"] === "number" || typeof r["value"] === "string") &&
      !("error" in v.expect && v.expect["error"] !== "range")
    );
  });
  const fromWire_ = VECTORS.filter((v) => requestOf(v)["op"] === "from_wire" && "value" in v.expect);

  it("holds enough vectors to mean something", () => {
    expect(toWire_.length).toBeGreaterThan(500);
    expect(fromWire_.length).toBeGreaterThan(150);
    expect(toWire_.filter((v) => v.expect["error"] === "range").length).toBeGreaterThan(150);
  });

  it("physical -> wire: rounding edges, out-of-range values, every quantity", () => {
    const failures = toWire_
      .map((v) => {
        const r = requestOf(v);
        return {
          name: v.name,
          expect: v.expect,
          got: libraryToWire(r["quantity"] as string, r["value"] as number | string),
        };
      })
      .filter((c) => JSON.stringify(c.got) !== JSON.stringify(c.expect));
    expect(failures).toEqual([]);
  });

  it("wire -> physical, exact to the step, signed by the direction flag", () => {
    const failures = fromWire_
      .map((v) => {
        const r = requestOf(v);
        const got = libraryFromWire(r["quantity"] as string, r["wire"] as number, (r["direction"] as number) ?? 0);
        return { name: v.name, expect: v.expect["value"], got };
      })
      .filter((c) => c.got !== c.expect && !(c.got === 0 && c.expect === 0));
    expect(failures).toEqual([]);
  });
});

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

  it("gives every 16-bit wire integer the double nearest its exact decimal value", () => {
    // the exact value raw x scale, written in decimal and parsed: what fromWire must return
    const exact = (raw: number, scale: number): number => {
      const [digits = "", decimals = ""] = String(scale).split(".");
      return Number(`${BigInt(raw) * BigInt(digits + decimals)}e-${decimals.length}`);
    };
    for (const scale of [0.01, 0.1, 0.001, 0.25, 0.3]) {
      for (let raw = -65535; raw <= 65535; raw++) {
        if (fromWire(raw, scale) !== exact(raw, scale))
          expect([raw, fromWire(raw, scale)]).toEqual([raw, exact(raw, scale)]);
      }
    }
    expect(Object.is(fromWire(-0, 0.01), 0)).toBe(true);
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
    expect(() => speedToWire(NaN)).toThrow(UnitRangeError);
  });

  it("says what is allowed when a motion value is out of range", () => {
    expect(() => positionToWire(655.335)).toThrow(
      /degrees = 655\.335 is out of range; allowed: -655\.33\.\.655\.33 deg/,
    );
    expect(() => speedToWire(0)).toThrow(/rpm = 0 is out of range; allowed: -6553\.3\.\.-0\.1 or 0\.1\.\.6553\.3 rpm/);
    expect(() => arrivalToWire(30)).toThrow(/seconds = 30 is out of range; allowed: 0\.1\.\.25\.5 s/);
  });

  it("describes ranges with their physical units", () => {
    const speed = SPECS.position_speed.fields[2]!;
    expect(describeRange(speed)).toBe("1..65533 (0.1..6553.3 rpm)");
    expect(describeRange(SPECS.position_speed.fields[0]!)).toBe("0..1 (0 ccw, 1 cw)");
  });
});
