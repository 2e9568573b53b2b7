// Plot styles: a colour per motor, a line style per signal, distinct at 24 series (issue #37).
import assert from "node:assert/strict";
import { join } from "node:path";
import { test } from "node:test";
import { STATIC } from "./paths.mjs";

const { MOTOR_COLOURS, SIGNAL_DASH, seriesStyle, WINDOWS_S } = await import(join(STATIC, "core/plotstyle.js"));

const rgb = (hex) => [1, 3, 5].map((i) => Number.parseInt(hex.slice(i, i + 2), 16));
const distance = (a, b) => Math.hypot(...rgb(a).map((v, i) => v - rgb(b)[i]));

test("24 motors get 24 colours, each far enough from every other to be told apart", () => {
  const colours = Array.from({ length: 24 }, (_, i) => seriesStyle(i, "position").stroke);
  assert.equal(new Set(colours).size, 24);
  for (let i = 0; i < 24; i++)
    for (let j = i + 1; j < 24; j++)
      assert.ok(distance(colours[i], colours[j]) >= 40, `${colours[i]} and ${colours[j]} are too alike`);
  assert.equal(MOTOR_COLOURS.length, 24);
});

test("every mix of up to 24 series is distinct: 4 motors x 6 signals, 12 x 2, 24 x 1", () => {
  const signals = Object.keys(SIGNAL_DASH);
  assert.equal(new Set(signals.map((s) => JSON.stringify(SIGNAL_DASH[s] ?? null))).size, signals.length);
  for (const [motors, kinds] of [
    [4, 6],
    [12, 2],
    [24, 1],
  ]) {
    const styles = [];
    for (let m = 0; m < motors; m++)
      for (const signal of signals.slice(0, kinds)) styles.push(JSON.stringify(seriesStyle(m, signal)));
    assert.equal(new Set(styles).size, motors * kinds, `${motors} motors x ${kinds} signals`);
  }
  // the case: ID 6's position no longer has ID 1's colour
  assert.notEqual(seriesStyle(5, "position").stroke, seriesStyle(0, "position").stroke);
});

test("the selectable time windows fit in what the series keep (60 s)", () => {
  assert.ok(WINDOWS_S.includes(10) && Math.max(...WINDOWS_S) <= 60);
});
