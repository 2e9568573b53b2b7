import fc from "fast-check";
import { describe, expect, it } from "vitest";
import { BY_MODE, decode, encode, type Message, make, toRecord } from "../src/codec.js";
import { MESSAGE_NAMES } from "../src/generated/messages.js";
import { SPECS } from "../src/generated/tables.js";
import { emptyStats, type ParserStats, StreamParser } from "../src/parser.js";
import { concat } from "./fake-port.js";

const anyMessage: fc.Arbitrary<Message> = fc.constantFrom(...MESSAGE_NAMES).chain((name) => {
  const spec = SPECS[name];
  const fields = Object.fromEntries(spec.fields.map((f) => [f.name, fc.integer({ min: f.min, max: f.max })]));
  return fc
    .record({ id: fc.integer({ min: 0, max: spec.maxId }), f: fc.record(fields) })
    .map(({ id, f }) => make(name as string, id, f));
});

function parseAll(stream: Uint8Array, cuts: number[]): { frames: Message[]; dropped: number } {
  const parser = new StreamParser();
  const frames: Message[] = [];
  let last = 0;
  for (const cut of [...cuts].sort((a, b) => a - b)) {
    frames.push(...parser.feed(stream.subarray(last, cut)));
    last = cut;
  }
  frames.push(...parser.feed(stream.subarray(last)), ...parser.finish());
  return { frames, dropped: parser.stats.droppedBytes };
}

/** The rule applied offline to a whole input, independently of the streaming code: at each
 * position judge the candidate there on all the bytes that follow (size byte, mode, the mode's
 * size, checksum); take a valid frame and continue after it, else drop one byte. */
function offlineRule(bytes: Uint8Array): { frames: Message[]; stats: ParserStats } {
  const stats = emptyStats();
  const frames: Message[] = [];
  let pos = 0;
  while (pos < bytes.length) {
    const avail = bytes.length - pos;
    const size = bytes[pos + 3] ?? 0;
    const spec = BY_MODE.get(bytes[pos + 5] ?? -1);
    if (avail >= 4 && bytes[pos] === 0xff && bytes[pos + 1] === 0xfe) {
      if (size < 2 || size > 8) stats.badSize += 1;
      else if (avail < 6) {
        // cut off by the end: dropped, not counted
      } else if (spec === undefined) stats.unknownMode += 1;
      else if (spec.size !== size) stats.badSize += 1;
      else if (avail >= size + 4) {
        try {
          frames.push(decode(bytes.subarray(pos, pos + size + 4)));
          stats.frames += 1;
          pos += size + 4;
          continue;
        } catch {
          stats.badChecksum += 1;
        }
      }
    }
    stats.droppedBytes += 1;
    pos += 1;
  }
  return { frames, stats };
}

/** Frames, fragments, frames with one flipped bit after the header, FF FE pairs and noise. */
const hostileStream = fc
  .array(
    fc.oneof(
      fc.uint8Array({ maxLength: 6 }),
      fc.constant(new Uint8Array([0xff, 0xfe])),
      anyMessage.map(encode),
      fc.tuple(anyMessage.map(encode), fc.nat()).map(([f, cut]) => f.subarray(0, cut % f.length)),
      fc.tuple(anyMessage.map(encode), fc.nat(), fc.integer({ min: 0, max: 7 })).map(([f, at, bit]) => {
        const g = f.slice();
        const i = 2 + (at % (g.length - 2));
        g[i] = (g[i] ?? 0) ^ (1 << bit);
        return g;
      }),
    ),
    { maxLength: 40 },
  )
  .map((p) => concat(...p));

describe("stream parser", () => {
  it("finds every frame between noise that holds no header byte, and counts the noise", () => {
    const noise = fc.uint8Array({ maxLength: 5 }).map((b) => b.map((x) => x % 0xff)); // no FF
    fc.assert(
      fc.property(fc.array(fc.tuple(noise, anyMessage), { maxLength: 8 }), noise, (parts, tail) => {
        const stream = concat(...parts.flatMap(([n, m]) => [n, encode(m)]), tail);
        const { frames, dropped } = parseAll(stream, []);
        expect(frames.map(toRecord)).toEqual(parts.map(([, m]) => toRecord(m)));
        expect(dropped).toBe(parts.reduce((sum, [n]) => sum + n.length, 0) + tail.length);
      }),
      { numRuns: 500 },
    );
  });

  it("gives the same result however the stream is chunked, on any bytes", () => {
    const stream = fc
      .array(
        fc.oneof(fc.uint8Array({ maxLength: 6 }), anyMessage.map(encode), fc.constant(new Uint8Array([0xff, 0xfe]))),
        { maxLength: 10 },
      )
      .map((p) => concat(...p));
    fc.assert(
      fc.property(stream, fc.array(fc.nat(), { maxLength: 10 }), (bytes, cuts) => {
        const whole = parseAll(bytes, []);
        const chunked = parseAll(
          bytes,
          cuts.map((c) => c % (bytes.length + 1)),
        );
        expect(chunked.frames).toEqual(whole.frames);
        expect(chunked.dropped).toBe(whole.dropped);
        const frameBytes = whole.frames.reduce((n, m) => n + SPECS[m.name].size + 4, 0);
        expect(frameBytes + whole.dropped).toBe(bytes.length); // every byte is accounted for
      }),
      { numRuns: 1000 },
    );
  });

  it("matches the rule applied offline, frames and every counter, however the input is chunked", () => {
    fc.assert(
      fc.property(hostileStream, fc.array(fc.nat(), { maxLength: 12 }), (bytes, cuts) => {
        const expected = offlineRule(bytes);
        const parser = new StreamParser();
        const frames: Message[] = [];
        let last = 0;
        for (const cut of cuts.map((c) => c % (bytes.length + 1)).sort((a, b) => a - b)) {
          frames.push(...parser.feed(bytes.subarray(last, cut)));
          expect(parser.pending).toBeLessThan(12);
          last = cut;
        }
        frames.push(...parser.feed(bytes.subarray(last)), ...parser.finish());
        expect(frames).toEqual(expected.frames);
        expect(parser.stats).toEqual(expected.stats);
        expect(parser.pending).toBe(0);
      }),
      { numRuns: 1500 },
    );
  });

  it("parses a large input in one call, and the same byte by byte", () => {
    const messages = Array.from({ length: 5000 }, (_, i) => {
      const spec = SPECS[MESSAGE_NAMES[i % MESSAGE_NAMES.length] as (typeof MESSAGE_NAMES)[number]];
      return make(spec.name, i % 200, Object.fromEntries(spec.fields.map((f) => [f.name, f.max])));
    });
    const stream = concat(...messages.map(encode));
    const whole = new StreamParser();
    expect(whole.feed(stream)).toEqual(messages);
    expect(whole.pending).toBe(0);
    const byByte = new StreamParser();
    const frames: Message[] = [];
    for (let i = 0; i < stream.length; i++) frames.push(...byByte.feed(stream.subarray(i, i + 1)));
    expect(frames).toEqual(messages);
    expect(byByte.stats).toEqual({ ...emptyStats(), frames: messages.length });
  });

  it("keeps bounded memory and never throws on garbage", () => {
    const parser = new StreamParser();
    fc.assert(
      fc.property(fc.uint8Array({ maxLength: 64 }), (bytes) => {
        parser.feed(bytes);
        expect(parser.pending).toBeLessThan(12); // never more than one frame's worth
      }),
      { numRuns: 2000 },
    );
  });

  it("finds a real frame behind a false header and counts the diagnostics", () => {
    const real = encode(make("ping", 3, {}));
    const falseHeader = new Uint8Array([0xff, 0xfe, 0x01, 0x02, 0x00, 0xd0]); // bad checksum
    const unknownMode = new Uint8Array([0xff, 0xfe, 0x01, 0x02, 0x00, 0x77]);
    const badSize = new Uint8Array([0xff, 0xfe, 0x01, 0x09]);
    const parser = new StreamParser();
    const frames = [...parser.feed(concat(falseHeader, unknownMode, badSize, real)), ...parser.finish()];
    expect(frames).toEqual([make("ping", 3, {})]);
    expect(parser.stats).toMatchObject({ frames: 1, badChecksum: 1, unknownMode: 1, badSize: 1, droppedBytes: 16 });
  });

  it("waits for the rest of a split frame, and drops a partial frame at finish", () => {
    const frame = encode(make("position_feedback", 7, { direction: 0, position: 18000, speed: 0, current: 0 }));
    const parser = new StreamParser();
    expect(parser.feed(frame.subarray(0, 7))).toEqual([]);
    expect(parser.pending).toBe(7);
    expect(parser.feed(frame.subarray(7)).map(toRecord)).toEqual([
      { id: 7, message: "position_feedback", direction: 0, position: 18000, speed: 0, current: 0 },
    ]);
    parser.feed(frame.subarray(0, 5));
    expect(parser.finish()).toEqual([]);
    expect(parser.stats.droppedBytes).toBe(5);
  });
});
