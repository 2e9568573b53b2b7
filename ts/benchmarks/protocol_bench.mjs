// Micro-benchmark of the TypeScript protocol layer, with the hand-written parser it must beat.
// Usage: node benchmarks/protocol_bench.mjs [--quick]   (after `npx tsc -p .`)
//
// Stream parsing is measured against `HandParser` below, the parser a user would write by hand
// in JavaScript (TypedArray.indexOf for the header, a Map from mode to layout, the checksum
// loop, the same message objects out: {name, id, <fields>}), on the same streams and chunkings:
// mixed messages and position feedback, in 256-, 64- and 12-byte chunks. The two run in
// interleaved rounds (A B, B A, A B, ...) so that a slow moment of the machine hits both; the
// figure is the median round, and the ratio is hand-written time / StreamParser time (above
// 1.0 = StreamParser is faster). Same method as benchmarks/protocol_bench.py; see
// docs/performance.md. Encode and decode rates are printed for reference.
// Writes benchmarks/results/protocol-ts.json (not with --quick). Not a test: figures vary with
// the machine and never fail anything.
import { writeFileSync } from "node:fs";
import { arch, cpus } from "node:os";
import { fileURLToPath } from "node:url";
import { decode, encode, MESSAGE_NAMES, make, SPECS, StreamParser } from "../dist/index.js";

const QUICK = process.argv.includes("--quick");
const COUNT = 20_000;
const ROUNDS = QUICK ? 5 : 31;

let seed = 1;
const random = () => {
  seed = (seed * 1103515245 + 12345) & 0x7fffffff;
  return seed / 0x80000000;
};
const randint = (min, max) => min + Math.floor(random() * (max - min + 1));

/** The baseline: a straightforward, reasonably optimised hand-written JavaScript stream parser.
 * Same stream rule as StreamParser (a bad candidate costs one byte) and the same message
 * objects out, but no diagnostics counters. */
class HandParser {
  static LAYOUTS = new Map(
    Object.values(SPECS).map((spec) => [
      spec.mode,
      { size: spec.size, name: spec.name, fields: spec.fields.map((f) => ({ name: f.name, width: f.width })) },
    ]),
  );

  buf = new Uint8Array(0);

  feed(chunk) {
    let buf = chunk;
    if (this.buf.length > 0) {
      buf = new Uint8Array(this.buf.length + chunk.length);
      buf.set(this.buf);
      buf.set(chunk, this.buf.length);
    }
    const layouts = HandParser.LAYOUTS;
    const out = [];
    const n = buf.length;
    let pos = 0;
    for (;;) {
      const start = buf.indexOf(0xff, pos);
      if (start < 0) {
        pos = n;
        break;
      }
      pos = start;
      if (n - start < 6) break; // may begin a frame: keep it
      if (buf[start + 1] !== 0xfe) {
        pos += 1;
        continue;
      }
      const size = buf[start + 3];
      const layout = layouts.get(buf[start + 5]);
      if (layout === undefined || layout.size !== size) {
        pos += 1;
        continue;
      }
      const end = start + size + 4;
      if (end > n) break;
      let sum = buf[start + 2] + size;
      for (let i = start + 5; i < end; i++) sum += buf[i];
      if (buf[start + 4] !== (~sum & 0xff)) {
        pos += 1;
        continue;
      }
      const message = { name: layout.name, id: buf[start + 2] };
      let at = start + 6;
      for (const field of layout.fields) {
        message[field.name] = field.width === 2 ? (buf[at] << 8) | buf[at + 1] : buf[at];
        at += field.width;
      }
      out.push(message);
      pos = end;
    }
    this.buf = buf.slice(pos);
    return out;
  }
}

function sampleMessages(names) {
  return Array.from({ length: COUNT }, () => {
    const spec = SPECS[names[randint(0, names.length - 1)]];
    const fields = Object.fromEntries(spec.fields.map((f) => [f.name, randint(f.min, f.max)]));
    return make(spec.name, randint(0, spec.maxId), fields);
  });
}

function streamOf(messages) {
  const frames = messages.map(encode);
  const stream = new Uint8Array(frames.reduce((n, f) => n + f.length, 0));
  let at = 0;
  for (const frame of frames) {
    stream.set(frame, at);
    at += frame.length;
  }
  return { frames, stream };
}

const chunked = (stream, size) =>
  Array.from({ length: Math.ceil(stream.length / size) }, (_, i) => stream.subarray(i * size, (i + 1) * size));

function runOurs(chunks) {
  const parser = new StreamParser();
  let count = 0;
  for (const chunk of chunks) count += parser.feed(chunk).length;
  return count;
}

function runHand(chunks) {
  const parser = new HandParser();
  let count = 0;
  for (const chunk of chunks) count += parser.feed(chunk).length;
  return count;
}

function timed(fn, chunks) {
  const start = process.hrtime.bigint();
  const got = fn(chunks);
  const seconds = Number(process.hrtime.bigint() - start) / 1e9;
  if (got !== COUNT) throw new Error(`${fn.name} returned ${got} of ${COUNT} frames`);
  return seconds;
}

const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
};
const round = (x, digits = 1) => Math.round(x * 10 ** digits) / 10 ** digits;

/** Interleaved rounds of the library's parser and the hand-written one on the same chunks. */
function compare(chunks) {
  for (let i = 0; i < 3; i++) {
    // warm up the JIT
    runOurs(chunks);
    runHand(chunks);
  }
  const ours = [];
  const hand = [];
  const ratios = [];
  for (let r = 0; r < ROUNDS; r++) {
    // the order alternates, so neither parser always runs first in a round
    let a;
    let b;
    if (r % 2) {
      b = timed(runHand, chunks);
      a = timed(runOurs, chunks);
    } else {
      a = timed(runOurs, chunks);
      b = timed(runHand, chunks);
    }
    ours.push(a);
    hand.push(b);
    ratios.push(b / a);
  }
  return {
    stream_parser_frames_per_s: round(COUNT / median(ours)),
    hand_written_frames_per_s: round(COUNT / median(hand)),
    ratio: round(median(ratios), 3),
    ratio_of_median_times: round(median(hand) / median(ours), 3),
  };
}

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

const mixed = streamOf(sampleMessages(MESSAGE_NAMES));
const feedback = streamOf(sampleMessages(["position_feedback"]));
const parsing = {};
for (const [name, { stream }] of Object.entries({ mixed, feedback })) {
  for (const size of [256, 64, 12]) parsing[`${name}_${size}_byte_chunks`] = compare(chunked(stream, size));
}
const minRatio = Math.min(...Object.values(parsing).map((p) => p.ratio));
const messages = sampleMessages(MESSAGE_NAMES);
const codec = {
  encode_frames_per_s: round(bestRate(() => messages.forEach(encode))),
  decode_frames_per_s: round(bestRate(() => mixed.frames.forEach(decode))),
  parse_MB_per_s_mixed_256: round(
    (parsing.mixed_256_byte_chunks.stream_parser_frames_per_s * mixed.stream.length) / COUNT / 1e6,
  ),
  wire_frames_per_s_at_1Mbps: round(1e6 / 10 / (mixed.stream.length / COUNT)),
};
console.table(parsing);
console.table(codec);
console.log(`min ratio (hand-written time / StreamParser time): ${minRatio}`);
const out = {
  benchmark:
    "ts/benchmarks/protocol_bench.mjs: StreamParser against a hand-written JavaScript parser (TypedArray.indexOf + Map of layouts + checksum loop, the same message objects out) on the same chunks, interleaved rounds; ratio = hand-written time / StreamParser time, the median over rounds (>= 1.0: StreamParser is as fast or faster); ratio_of_median_times = the same from the median times",
  parsing,
  min_ratio: minRatio,
  codec,
  frames_per_stream: COUNT,
  rounds: ROUNDS,
  node: process.version,
  machine: arch(),
  cpu: cpus()[0]?.model ?? "",
  date: new Date().toISOString().slice(0, 10),
};
if (!QUICK) {
  writeFileSync(
    fileURLToPath(new URL("results/protocol-ts.json", import.meta.url)),
    `${JSON.stringify(out, null, 2)}\n`,
  );
}
