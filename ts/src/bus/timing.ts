/**
 * How long an answer may take: derived from the wire, never guessed (the Python
 * library's rule, nurimc.core.timing, with the same defaults).
 *
 * deadline (from the end of our write) = request wire time + the controller's response
 * time + answer wire time + adapter latency (both ways) + a small margin. Bytes are 10
 * bits on the wire (8N1: start, 8 data, stop). A controller whose response-time setting
 * is unknown is assumed to use the largest (254 x 100 us = 25.4 ms).
 */
import { HOST_TIMING } from "../generated/host.js";

export const BITS_PER_BYTE = HOST_TIMING.bitsPerByte;
/** The largest response-time setting, in microseconds. */
export const MAX_RESPONSE_TIME_US = HOST_TIMING.maxResponseTimeUs;

export interface Timing {
  /** Adapter latency each way, ms (USB adapters: 1-16 ms; FTDI's latency timer defaults to 16). Default 2 (spec/host.json). */
  latencyMs: number;
  /** Scheduling slack of a busy host, ms. Default 3. */
  marginMs: number;
  /** Response time assumed for a controller whose setting is unknown, us. Default 25,400 (the largest). */
  assumedResponseTimeUs: number;
}

/** The defaults of spec/host.json (`timing`). */
export const DEFAULT_TIMING: Readonly<Timing> = {
  latencyMs: HOST_TIMING.adapterLatencyMs,
  marginMs: HOST_TIMING.marginMs,
  assumedResponseTimeUs: MAX_RESPONSE_TIME_US,
};

/** Milliseconds `bytes` take on the wire at `baudRate`. */
export function wireTimeMs(bytes: number, baudRate: number): number {
  return (bytes * BITS_PER_BYTE * 1000) / baudRate;
}

/** The longest a real answer can take after the request is written; after that none is coming. */
export function answerDeadlineMs(
  requestBytes: number,
  answerBytes: number,
  baudRate: number,
  responseTimeUs: number | undefined,
  timing: Readonly<Timing> = DEFAULT_TIMING,
): number {
  const response = (responseTimeUs ?? timing.assumedResponseTimeUs) / 1000;
  return wireTimeMs(requestBytes + answerBytes, baudRate) + response + 2 * timing.latencyMs + timing.marginMs;
}
