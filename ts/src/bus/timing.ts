/**
 * How long an answer can take, from what the wire and the controller allow.
 *
 * request on the wire + the controller's response time + answer on the wire + the
 * adapter's latency. Bytes are 10 bits on the wire (8N1: start, 8 data, stop).
 * USB-RS485 adapters hold received bytes for 1-16 ms before the host sees them
 * (FTDI's latency timer defaults to 16 ms), hence the adapter latency term.
 */
export const BITS_PER_BYTE = 10;

/** Default adapter latency: covers a USB adapter at its default latency timer, with room to spare. */
export const DEFAULT_ADAPTER_LATENCY_MS = 20;

/** Milliseconds `bytes` take on the wire at `baudRate`. */
export function wireTimeMs(bytes: number, baudRate: number): number {
  return (bytes * BITS_PER_BYTE * 1000) / baudRate;
}

export interface AnswerTiming {
  requestBytes: number;
  answerBytes: number;
  baudRate: number;
  /** The controller's response-time setting in microseconds (100 us per step; default 100 us). */
  responseTimeUs: number;
  adapterLatencyMs: number;
}

/** The longest a real answer can take; after that none is coming. */
export function answerTimeoutMs(t: AnswerTiming): number {
  return wireTimeMs(t.requestBytes, t.baudRate) + t.responseTimeUs / 1000 + wireTimeMs(t.answerBytes, t.baudRate) + t.adapterLatencyMs;
}
