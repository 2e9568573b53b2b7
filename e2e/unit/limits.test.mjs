// Every limit, rate and unit comes from the generated spec (core/limits.js re-exports it): this
// fails if a view, a link, the page's HTML or a catalog types one of them again.
import assert from "node:assert/strict";
import { readdirSync, readFileSync } from "node:fs";
import { join } from "node:path";
import { test } from "node:test";
import { STATIC } from "./paths.mjs";

const spec = await import(join(STATIC, "generated/spec.js"));
const limits = await import(join(STATIC, "core/limits.js"));

test("core/limits.js takes its values from the generated spec", () => {
  assert.equal(limits.MOVE_LIMIT, spec.LIMITS.positionDeg);
  assert.equal(limits.RPM_MAX, spec.LIMITS.speedRpmMax);
  assert.equal(limits.RPM_MIN, spec.LIMITS.speedRpmMin);
  assert.equal(limits.BAUD_RATES, spec.BAUD_RATES);
  assert.ok(spec.BAUD_RATES.includes(limits.DEFAULT_BAUD));
});

test("no file of the page retypes a limit, a rate or the ID range", () => {
  const files = [
    "app.js",
    "index.html",
    "direct-link.js",
    "server-link.js",
    ...readdirSync(join(STATIC, "views")).map((f) => `views/${f}`),
    ...readdirSync(join(STATIC, "core"))
      .filter((f) => f !== "limits.js")
      .map((f) => `core/${f}`),
    ...readdirSync(join(STATIC, "locales")).map((f) => `locales/${f}`),
  ];
  const numbers = [
    ...Object.values(spec.LIMITS).filter((v) => v > 1), // 0.1 (RPM, seconds) is too ordinary a number to tell apart
    ...spec.BAUD_RATES.filter((rate) => rate >= 1200), // 110..600 are too ordinary to tell apart from other numbers
    limits.MAX_ID,
    limits.MAX_ID + 1,
    ...new Set(spec.SETTINGS.flatMap((s) => [s.physicalMax]).filter((v) => v > 100)),
  ];
  const found = [];
  for (const file of files) {
    const lines = readFileSync(join(STATIC, file), "utf8").split("\n");
    lines.forEach((line, i) => {
      const code = line.replace(/^\s*\/\/.*$/, "").replace(/\/\/ .*$/, ""); // comments may cite the document
      for (const n of numbers) {
        const pattern = new RegExp(`(?<![\\w.])${String(n).replace(".", "\\.")}(?![\\w.]*\\d)`);
        if (pattern.test(code)) found.push(`${file}:${i + 1}: ${n}: ${line.trim().slice(0, 80)}`);
      }
    });
  }
  assert.deepEqual([...new Set(found)], []);
});
