// The pure parts of the page: series alignment, step figures, frame filters and the traffic
// log, motor state.
import assert from "node:assert/strict";
import { join } from "node:path";
import { test } from "node:test";
import { STATIC } from "./paths.mjs";

const { alignTracks, csv, signalValue, trim, windowStart } = await import(join(STATIC, "core/series.js"));
const { stepFigures } = await import(join(STATIC, "core/stepfigures.js"));
const { filterFrames, trafficLog } = await import(join(STATIC, "core/frames.js"));
const { motorState } = await import(join(STATIC, "core/motorstate.js"));

test("motors read in turn are aligned on one axis without gaps inside each series", () => {
  // three motors sampled one after another: each has its own times
  const tracks = [0, 1, 2].map((k) => {
    const t = Array.from({ length: 50 }, (_, i) => i * 0.03 + k * 0.01);
    return { t, v: t.map((x) => 10 * k + x) };
  });
  const [x, ...ys] = alignTracks(tracks, 1.5);
  assert.equal(x.length, 150);
  assert.ok(x.at(-1) < 0 && x.every((v, i) => i === 0 || v > x[i - 1]), "relative to now, ascending");
  ys.forEach((y, k) => {
    const inside = y.slice(3, -3);
    assert.ok(
      inside.every((v) => v != null),
      `series ${k} has no gaps inside`,
    );
    const first = y.findIndex((v) => v != null);
    assert.ok(Math.abs(y[first + 4] - (10 * k + x[first + 4] + 1.5)) < 1e-9, "interpolated on the line");
  });
});

test("a null (no target) stays a gap; windows and trimming", () => {
  const [, y] = alignTracks([
    { t: [0, 1, 2, 3], v: [1, null, 3, 4] },
    { t: [0.5, 2.5], v: [0, 0] },
  ]);
  assert.deepEqual(y, [1, null, null, 3, 3.5, 4]);
  assert.equal(windowStart([0, 1, 2, 3, 4], 4, 2), 2);
  const s = { t: [0, 1, 2, 3], position: [5, 6, 7, 8] };
  assert.equal(trim(s, 3, 1.5), 2);
  assert.deepEqual(s, { t: [2, 3], position: [7, 8] });
  assert.equal(signalValue({ target: [10, null], position: [7, 8] }, "error", 0), 3);
  assert.equal(signalValue({ target: [10, null], position: [7, 8] }, "error", 1), null);
  assert.equal(
    csv(
      ["a", "b"],
      [
        [1, null],
        ["x,y", 2],
      ],
    ),
    'a,b\n1,\n"x,y",2\n',
  );
});

test("step figures: rise 10-90 %, overshoot, settling in ±2 %, final error", () => {
  const times = Array.from({ length: 101 }, (_, i) => i / 100);
  const positions = times.map(
    (t) => 100 * (1 - Math.exp(-t / 0.1)) * (1 + 0.1 * Math.exp(-t / 0.05) * Math.sin(t * 60)),
  );
  const f = stepFigures(times, positions, 0, 100);
  assert.ok(f.rise > 0.18 && f.rise < 0.26, `rise ${f.rise}`); // ln(9) * 0.1 = 0.22 for a first-order step
  assert.ok(f.settling > 0.3 && f.settling < 0.5, `settling ${f.settling}`);
  assert.ok(Math.abs(f.finalError) < 0.01);
  assert.equal(f.settled, true);
  const over = stepFigures([0, 1, 2, 3], [0, 120, 95, 100], 0, 100);
  assert.ok(Math.abs(over.overshoot - 20) < 1e-9);
  assert.equal(stepFigures([0, 1], [0, 50], 0, 100).settled, false);
  assert.equal(stepFigures([0, 1], [0, 50], 0, 100).settling, null);
  assert.equal(stepFigures([], [], 0, 100), null);
});

const frames = [
  { t: 0.1, dir: "tx", id: 1, name: "request_position", fields: {}, hex: "ff fe 01 02 58 a2" },
  {
    t: 0.11,
    dir: "rx",
    id: 1,
    name: "position_feedback",
    fields: { position: 1 },
    hex: "ff fe 01 07 00 00 00 00 00 00 00",
  },
  { t: 0.2, dir: "tx", id: 2, name: "set_control", fields: { control: "off" }, hex: "ff fe 02 03 0a 01 f0" },
  { t: 0.3, dir: "rx", id: null, name: "noise", fields: { bytes: 3 }, hex: "" },
];

test("raw frames: the console's polling hidden by default; filters by ID, message, direction, text", () => {
  assert.deepEqual(
    filterFrames(frames).map((f) => f.name),
    ["set_control", "noise"],
  );
  assert.equal(filterFrames(frames, { polling: true }).length, 4);
  assert.deepEqual(
    filterFrames(frames, { polling: true, id: "1" }).map((f) => f.name),
    ["request_position", "position_feedback"],
  );
  assert.deepEqual(
    filterFrames(frames, { polling: true, dir: "rx", id: "1, 2" }).map((f) => f.name),
    ["position_feedback"],
  );
  assert.deepEqual(filterFrames(frames, { polling: true, message: "set_control" }).length, 1);
  assert.deepEqual(
    filterFrames(frames, { search: "off" }).map((f) => f.name),
    ["set_control"],
  );
});

test("the traffic log is what `nurimc replay` reads: one {t, dir, hex} per line, bytes only", () => {
  const lines = trafficLog(frames)
    .trim()
    .split("\n")
    .map((l) => JSON.parse(l));
  assert.equal(lines.length, 3, "the noise marker has no bytes");
  assert.deepEqual(lines[2], { t: 0.2, dir: "tx", hex: "fffe02030a01f0" });
  assert.ok(lines.every((l) => Object.keys(l).join() === "t,dir,hex"));
});

test("a motor's badge: stopped until a command, busy, silent, off, moving, on", () => {
  const base = { stopped: false, busy: 0, control: "on", lastSampleAt: 10, lastErrorAt: null, speed: 0 };
  assert.equal(motorState(base, 10.1), "on");
  assert.equal(motorState({ ...base, speed: 30 }, 10.1), "moving");
  assert.equal(motorState({ ...base, control: "off" }, 10.1), "off");
  assert.equal(motorState({ ...base, lastSampleAt: 8 }, 10.1), "silent");
  assert.equal(motorState({ ...base, lastErrorAt: 10.05 }, 10.1), "silent");
  assert.equal(motorState({ ...base, busy: 1, speed: 30 }, 10.1), "busy");
  assert.equal(motorState({ ...base, stopped: true, busy: 1, lastSampleAt: 1 }, 10.1), "stopped");
  assert.equal(motorState({ ...base, control: null }, 10.1), "unknown");
});

test("step figures: the shared vectors (spec/vectors/step-figures.json), as Python and the TS library", async () => {
  const { readFile } = await import("node:fs/promises");
  const url = new URL("../../spec/vectors/step-figures.json", import.meta.url);
  const { cases } = JSON.parse(await readFile(url, "utf8"));
  const near = (mine, theirs, tolerance, what) => {
    assert.equal(mine === null, theirs === null, what);
    if (mine !== null) assert.ok(Math.abs(mine - theirs) <= tolerance, `${what}: ${mine} vs ${theirs}`);
  };
  for (const c of cases) {
    const f = stepFigures(c.times, c.positions, c.start, c.target);
    if (c.error) {
      assert.equal(f, null, c.name);
      continue;
    }
    near(f.rise, c.expect.rise, 1e-9, `${c.name}: rise`);
    near(f.settling, c.expect.settling, 1e-9, `${c.name}: settling`);
    near(f.overshoot, c.expect.overshoot, 0.005, `${c.name}: overshoot`);
    near(f.finalError, c.expect.final_error, 0.0005, `${c.name}: final error`);
    assert.equal(f.settled, c.expect.settled, `${c.name}: settled`);
  }
});
