// Micro-benchmark of the TypeScript protocol layer: frames/s for encode, decode, stream parsing.
// Usage: node benchmarks/protocol_bench.mjs   (after `npx tsc -p .`)
// Prints the figures and writes benchmarks/results/protocol-ts.json. Not a test: figures vary
// with the machine; the results file records the machine next to them. Same method as
// benchmarks/protocol_bench.py (20,000 random valid frames, best of 5 runs).
import { writeFileSync } from "node:fs";
import { arch, cpus } from "node:os";
import { fileURLToPath } from "node:url";
import { decode, encode, MESSAGE_NAMES, make, SPECS, StreamParser } from "../dist/index.js";

const COUNT = 20_000;
let seed = 1;
const random = () => {
  seed = (seed * 1103515245 + 12345) & 0x7fffffff;
  return seed / 0x80000000;
};
const randint = (min, max) => min + Math.floor(random() * (max - min + 1));

const messages = Array.from({ length: COUNT }, () => {
  const spec = SPECS[MESSAGE_NAMES[randint(0, MESSAGE_NAMES.length - 1)]];
  const fields = Object.fromEntries(spec.fields.map((f) => [f.name, randint(f.min, f.max)]));
  return make(spec.name, randint(0, spec.maxId), fields);
});
const frames = messages.map(encode);
const stream = new Uint8Array(frames.reduce((n, f) => n + f.length, 0));
frames.reduce((at, f) => (stream.set(f, at), at + f.length), 0);

function bestRate(fn, repeat = 5) {
  fn(); // warm up the JIT
  let best = Infinity;
  for (let i = 0; i < repeat; i++) {
    const start = process.hrtime.bigint();
    fn();
    best = Math.min(best, Number(process.hrtime.bigint() - start) / 1e9);
  }
  return COUNT / best;
}

const round = (x) => Math.round(x * 10) / 10;
const parseRate = bestRate(() => {
  const parser = new StreamParser();
  for (let at = 0; at < stream.length; at += 256) parser.feed(stream.subarray(at, at + 256));
  if (parser.stats.frames !== COUNT) throw new Error("parser lost frames");
});
const results = {
  encode_frames_per_s: round(bestRate(() => messages.forEach(encode))),
  decode_frames_per_s: round(bestRate(() => frames.forEach(decode))),
  parse_frames_per_s: round(parseRate),
  parse_MB_per_s: round((parseRate * stream.length) / COUNT / 1e6),
  wire_frames_per_s_at_1Mbps: round(1e6 / 10 / (stream.length / COUNT)),
};
console.table(results);
const out = {
  results,
  frames: COUNT,
  node: process.version,
  machine: arch(),
  cpu: cpus()[0]?.model ?? "",
  date: new Date().toISOString().slice(0, 10),
};
writeFileSync(fileURLToPath(new URL("results/protocol-ts.json", import.meta.url)), JSON.stringify(out, null, 2) + "\n");
