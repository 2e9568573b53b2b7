/** Frame layout: header, ID, size, checksum, mode, data (docs/protocol.md). */
import { HEADER } from "./generated/tables.js";

export const ID_OFFSET = 2;
export const SIZE_OFFSET = 3;
export const CHECKSUM_OFFSET = 4;
export const MODE_OFFSET = 5;
export const DATA_OFFSET = 6;
export const HEADER_0 = HEADER[0] ?? 0xff;
export const HEADER_1 = HEADER[1] ?? 0xfe;

/** ~(ID + size + mode + every data byte) & 0xFF: every byte but header and checksum. */
export function checksum(frameId: number, size: number, mode: number, data: ArrayLike<number>): number {
  let sum = frameId + size + mode;
  for (let i = 0; i < data.length; i++) sum += data[i] ?? 0;
  return ~sum & 0xff;
}

/** The checksum the bytes of the frame at `start` (of length size + 4) call for. */
export function expectedChecksum(buf: Uint8Array, start: number, end: number): number {
  let sum = 0;
  for (let i = start + ID_OFFSET; i < start + CHECKSUM_OFFSET; i++) sum += buf[i] ?? 0;
  for (let i = start + MODE_OFFSET; i < end; i++) sum += buf[i] ?? 0;
  return ~sum & 0xff;
}

export function buildFrame(frameId: number, mode: number, data: Uint8Array): Uint8Array {
  const size = data.length + 2;
  const out = new Uint8Array(size + 4);
  out.set([HEADER_0, HEADER_1, frameId, size, checksum(frameId, size, mode, data), mode]);
  out.set(data, DATA_OFFSET);
  return out;
}

/** Lower-case contiguous hex, e.g. "fffe0002". */
export function toHex(bytes: Uint8Array): string {
  let out = "";
  for (const b of bytes) out += b.toString(16).padStart(2, "0");
  return out;
}

/** Contiguous hex digit pairs in either case -> bytes; anything else throws a RangeError. */
export function fromHex(text: string): Uint8Array {
  if (!/^(?:[0-9a-fA-F]{2})*$/.test(text)) {
    throw new RangeError(`not hex: ${JSON.stringify(text)} (expected contiguous pairs of hex digits)`);
  }
  const out = new Uint8Array(text.length / 2);
  for (let i = 0; i < out.length; i++) out[i] = parseInt(text.slice(2 * i, 2 * i + 2), 16);
  return out;
}
