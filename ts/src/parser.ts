/**
 * The stream parser: bytes in any chunking -> whole frames, plus counted diagnostics.
 *
 * The rule (conformance/README.md, the same in every language): scanning from the
 * first byte, where a whole valid frame starts, take it; otherwise drop one byte and
 * look again from the next. So a false header costs one byte and a real frame behind
 * it is never lost. Candidates are rejected as early as their bytes allow (a size byte
 * no message has, an unknown mode), so the buffer never holds more than one frame's
 * worth of bytes between calls and a false header never holds later frames hostage.
 *
 * Speed (docs/performance.md): a chunk is scanned where it lies, never copied; only the
 * few bytes of an undecided candidate at its end are kept (at most 11), and the next
 * chunk first completes them in a small fixed buffer with just enough of its bytes.
 * Modes are looked up in a 256-entry table, the checksum is summed inline.
 */
import { BY_MODE, decodeValid, type Message } from "./codec.js";
import { CHECKSUM_OFFSET, HEADER_0, HEADER_1, ID_OFFSET, MODE_OFFSET, SIZE_OFFSET } from "./frame.js";
import { MAX_SIZE } from "./generated/tables.js";
import type { MessageSpec } from "./schema.js";

/** The longest frame (size byte MAX_SIZE plus header, ID, size and checksum bytes). */
const MAX_FRAME_LENGTH = MAX_SIZE + 4;
/** The spec of each mode byte, or undefined: an array index is cheaper than a Map lookup. */
const SPEC_OF_MODE: readonly (MessageSpec | undefined)[] = Array.from({ length: 256 }, (_, mode) => BY_MODE.get(mode));

/** What the parser has seen since it was made (or reset). */
export interface ParserStats {
  frames: number;
  /** every byte not part of a returned frame */
  droppedBytes: number;
  badChecksum: number;
  unknownMode: number;
  badSize: number;
}

export const emptyStats = (): ParserStats => ({
  frames: 0,
  droppedBytes: 0,
  badChecksum: 0,
  unknownMode: 0,
  badSize: 0,
});

/** Feed bytes, get messages. Never throws on garbage; memory stays bounded. */
export class StreamParser {
  readonly stats: ParserStats = emptyStats();
  /** The spec of each mode byte: MC's, or a product line's (src/lines.ts, `lineParser`). */
  private readonly specOfMode: readonly (MessageSpec | undefined)[];

  constructor(specOfMode: readonly (MessageSpec | undefined)[] = SPEC_OF_MODE) {
    this.specOfMode = specOfMode;
  }

  /** Held bytes, then room for the bytes of the next chunk that complete them. */
  private readonly buf = new Uint8Array(2 * MAX_FRAME_LENGTH);
  private length = 0;

  /** Bytes held back because they may begin a frame. */
  get pending(): number {
    return this.length;
  }

  /** Add bytes; return every frame they complete, in order. */
  feed(data: Uint8Array): Message[] {
    const out: Message[] = [];
    let from = 0;
    if (this.length > 0) {
      // Judge the held bytes with just enough of the new ones: any candidate that starts in
      // them is decided by the next MAX_FRAME_LENGTH - 1 bytes.
      const held = this.length;
      const taken = Math.min(data.length, MAX_FRAME_LENGTH - 1);
      this.buf.set(data.subarray(0, taken), held);
      const n = held + taken;
      const pos = this.scan(this.buf, 0, n, false, out);
      if (pos < held || taken === data.length) {
        // (pos < held only when the chunk ended: a candidate is decided within MAX_FRAME_LENGTH bytes)
        this.hold(this.buf, pos, n);
        if (taken < data.length) out.push(...this.feed(data.subarray(taken)));
        return out;
      }
      from = pos - held; // the rest is judged in place
      this.length = 0;
    }
    this.hold(data, this.scan(data, from, data.length, false, out), data.length);
    return out;
  }

  /** End of stream (or the line went quiet): resolve held bytes; a partial frame is dropped. */
  finish(): Message[] {
    const out: Message[] = [];
    this.hold(this.buf, this.scan(this.buf, 0, this.length, true, out), this.length);
    return out;
  }

  /** Forget held bytes (counted as dropped), e.g. before a new request. */
  clear(): void {
    this.stats.droppedBytes += this.length;
    this.length = 0;
  }

  /** Keep bytes[pos..n) (at most MAX_FRAME_LENGTH - 1 of them) for the next call. */
  private hold(bytes: Uint8Array, pos: number, n: number): void {
    if (bytes === this.buf) this.buf.copyWithin(0, pos, n);
    else this.buf.set(bytes.subarray(pos, n));
    this.length = n - pos;
  }

  /** Resolve what bytes[from..n) allows, appending frames to `out`; returns where it stopped. */
  private scan(buf: Uint8Array, from: number, n: number, final: boolean, out: Message[]): number {
    const stats = this.stats;
    let pos = from;
    while (pos < n) {
      let start = pos;
      while (start + 1 < n && (buf[start] !== HEADER_0 || buf[start + 1] !== HEADER_1)) start++;
      if (start + 1 >= n) {
        // no header: keep a last FF that may begin one
        const keep = !final && buf[n - 1] === HEADER_0 ? 1 : 0;
        stats.droppedBytes += n - keep - pos;
        pos = n - keep;
        break;
      }
      stats.droppedBytes += start - pos;
      pos = start;
      const avail = n - pos;
      if (avail >= 4) {
        const size = buf[pos + SIZE_OFFSET] ?? 0;
        if (size < 2 || size > MAX_SIZE) {
          stats.badSize += 1;
          stats.droppedBytes += 1;
          pos += 1;
          continue;
        }
        if (avail >= 6) {
          const spec = this.specOfMode[buf[pos + MODE_OFFSET] ?? 0];
          if (spec === undefined || spec.size !== size) {
            if (spec === undefined) stats.unknownMode += 1;
            else stats.badSize += 1;
            stats.droppedBytes += 1;
            pos += 1;
            continue;
          }
          const end = pos + size + 4;
          if (end <= n) {
            let sum = (buf[pos + ID_OFFSET] ?? 0) + size;
            for (let i = pos + MODE_OFFSET; i < end; i++) sum += buf[i] ?? 0;
            if (buf[pos + CHECKSUM_OFFSET] === (~sum & 0xff)) {
              out.push(decodeValid(spec, buf, pos));
              stats.frames += 1;
              pos = end;
            } else {
              stats.badChecksum += 1;
              stats.droppedBytes += 1;
              pos += 1;
            }
            continue;
          }
        }
      }
      if (!final) break; // an incomplete candidate: wait for more bytes
      stats.droppedBytes += 1;
      pos += 1;
    }
    return pos;
  }
}
