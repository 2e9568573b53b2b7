/**
 * The stream parser: bytes in any chunking -> whole frames, plus counted diagnostics.
 *
 * The rule (conformance/README.md, the same in every language): scanning from the
 * first byte, where a whole valid frame starts, take it; otherwise drop one byte and
 * look again from the next. So a false header costs one byte and a real frame behind
 * it is never lost. Candidates are rejected as early as their bytes allow (a size byte
 * no message has, an unknown mode), so the buffer never holds more than one frame's
 * worth of bytes between calls and a false header never holds later frames hostage.
 */
import { BY_MODE, decodeValid, type Message } from "./codec.js";
import { CHECKSUM_OFFSET, expectedChecksum, HEADER_0, HEADER_1, MODE_OFFSET, SIZE_OFFSET } from "./frame.js";
import { MAX_SIZE } from "./generated/tables.js";

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
  private buf = new Uint8Array(64);
  private length = 0;

  /** Bytes held back because they may begin a frame. */
  get pending(): number {
    return this.length;
  }

  /** Add bytes; return every frame they complete, in order. */
  feed(data: Uint8Array): Message[] {
    if (this.length + data.length > this.buf.length) {
      const grown = new Uint8Array(Math.max(this.buf.length * 2, this.length + data.length));
      grown.set(this.buf.subarray(0, this.length));
      this.buf = grown;
    }
    this.buf.set(data, this.length);
    this.length += data.length;
    return this.scan(false);
  }

  /** End of stream (or the line went quiet): resolve held bytes; a partial frame is dropped. */
  finish(): Message[] {
    return this.scan(true);
  }

  /** Forget held bytes (counted as dropped), e.g. before a new request. */
  clear(): void {
    this.stats.droppedBytes += this.length;
    this.length = 0;
  }

  private scan(final: boolean): Message[] {
    const { buf, stats } = this;
    const n = this.length;
    const out: Message[] = [];
    let pos = 0;
    while (pos < n) {
      const start = findHeader(buf, pos, n);
      if (start < 0) {
        const keep = !final && buf[n - 1] === HEADER_0 ? 1 : 0;
        stats.droppedBytes += n - keep - pos;
        pos = n - keep;
        break;
      }
      stats.droppedBytes += start - pos;
      pos = start;
      if (this.rejectEarly(pos, n)) {
        pos += 1;
        continue;
      }
      if (n - pos >= 6) {
        const spec = BY_MODE.get(buf[pos + MODE_OFFSET] ?? -1);
        const end = pos + (buf[pos + SIZE_OFFSET] ?? 0) + 4;
        if (spec !== undefined && end <= n) {
          if (buf[pos + CHECKSUM_OFFSET] === expectedChecksum(buf, pos, end)) {
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
      if (!final) break; // an incomplete candidate: wait for more bytes
      stats.droppedBytes += 1;
      pos += 1;
    }
    buf.copyWithin(0, pos, n);
    this.length = n - pos;
    return out;
  }

  /** True (and counted) if the candidate at pos is no frame, judging by the bytes present. */
  private rejectEarly(pos: number, n: number): boolean {
    if (n - pos < 4) return false;
    const size = this.buf[pos + SIZE_OFFSET] ?? 0;
    if (size < 2 || size > MAX_SIZE) {
      this.stats.badSize += 1;
    } else if (n - pos < 6) {
      return false;
    } else {
      const spec = BY_MODE.get(this.buf[pos + MODE_OFFSET] ?? -1);
      if (spec !== undefined && spec.size === size) return false;
      if (spec === undefined) this.stats.unknownMode += 1;
      else this.stats.badSize += 1;
    }
    this.stats.droppedBytes += 1;
    return true;
  }
}

function findHeader(buf: Uint8Array, from: number, n: number): number {
  for (let i = from; i + 1 < n; i++) {
    if (buf[i] === HEADER_0 && buf[i + 1] === HEADER_1) return i;
  }
  return -1;
}
