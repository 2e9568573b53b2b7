/**
 * Find every controller across the 18 rates and 255 IDs, and the product line of each: the
 * Python library's search (python/src/nurimc/discovery.py, docs/library.md), in the same order
 * (spec/host.json, discovery.rate_order) with the same waits derived from the wire.
 *
 * For each rate: one broadcast ping; silence until an answer would have begun means nobody
 * listens there. Clean answers name the controllers; only garbled bytes (several controllers
 * answering together) make it walk the IDs one by one at that rate with firmware requests,
 * each waiting only until an answer would have begun (measured by the broadcast). An ID whose
 * walk brought garbled bytes is asked alone again with the full deadline: garbled again is a
 * collision (several controllers share the ID). Then each find is asked its firmware (if the
 * broadcast found it) and the line questions of the vendor's rule (spec/lines.json, detection;
 * python/src/nurimc/products.py): mc, rsavw, rsa, then sm confirmed by its own ratio answer.
 * Discovery never writes a setting: only pings, firmware requests and the line questions go out.
 */
import type { Bus } from "./bus/client.js";
import type { BytePort } from "./bus/port.js";
import { answerDeadlineMs, type Timing, wireTimeMs } from "./bus/timing.js";
import { encode, type Message, make } from "./codec.js";
import { buildFrame } from "./frame.js";
import { DISCOVERY_RATE_ORDER, HOST_TIMING } from "./generated/host.js";
import { BAUD_RATES, BROADCAST_ID } from "./generated/tables.js";
import { encodeIn, lineMessageSpec, lineParser, makeIn } from "./lines.js";
import { StreamParser } from "./parser.js";

/** The rule in order: (line named by an answer, the request that line answers and others do not). */
export const LINE_RULE: readonly (readonly [string, string])[] = [
  ["mc", "request_direction"],
  ["rsavw", "request_echo"],
  ["rsa", "request_position_mode"],
  ["sm", "request_ratio"],
];
/** What each detected line is, for people (the rule's limits included). */
export const LINE_DESCRIPTIONS: Readonly<Record<string, string>> = {
  mc: "MC or BLMC-H",
  rsavw: "RSAVW",
  rsa: "RSA or SA",
  sm: "SM (table unknown: the agreed messages only)",
  unknown: "answers none of the line questions",
};
/** Response time assumed while walking IDs without a broadcast to measure it, ms. */
export const WALK_RESPONSE_MS = 5;
const PING_LENGTH = 6;
const FIRMWARE_ANSWER_LENGTH = 8;

export interface Found {
  id: number;
  baudrate: number;
  firmware: number | null;
  /** several controllers answer at this ID and rate */
  collision: boolean;
  /** the product line by the vendor's rule; "unknown" if none matched (or not asked) */
  line: string;
}

export interface DiscoveryProgress {
  rate: number;
  /** 0-based, of ratesTotal */
  rateIndex: number;
  ratesTotal: number;
  /** the ID being asked while walking, else null */
  walkingId: number | null;
  found: readonly Found[];
  /** "rates" while searching, "lines" while asking the finds their firmware and line */
  phase: "rates" | "lines";
}

export interface DiscoverOptions {
  /** rates to search (default all 18), searched in the order of spec/host.json */
  rates?: readonly number[];
  /** IDs to walk (default 0-254; given IDs are walked, no broadcast) */
  ids?: readonly number[];
  /** ask each find its product line (default true) */
  lines?: boolean;
  onProgress?: (progress: DiscoveryProgress) => void;
  /** a rate the port refused: noted, and the search goes on */
  onRateSkipped?: (rate: number, reason: string) => void;
  signal?: AbortSignal;
}

interface Heard {
  messages: Message[];
  /** bytes that formed no frame */
  garbled: number;
  /** ms from before the write to the last byte heard; null if none */
  span: number | null;
}

const sleep = (ms: number, signal: AbortSignal): Promise<void> =>
  new Promise((resolve, reject) => {
    if (signal.aborted) {
      reject(signal.reason);
      return;
    }
    const timer = setTimeout(() => {
      signal.removeEventListener("abort", abort);
      resolve();
    }, ms);
    const abort = (): void => {
      clearTimeout(timer);
      reject(signal.reason);
    };
    signal.addEventListener("abort", abort, { once: true });
  });

/**
 * Write `frame`, then listen: until `startWithinMs` for a first byte (none: silence), then until
 * `windowMs` after the write, or until `enough` says the answers wanted are in.
 */
async function exchange(
  port: BytePort,
  frame: Uint8Array,
  parser: StreamParser,
  windowMs: number,
  startWithinMs: number,
  signal: AbortSignal,
  enough: (messages: readonly Message[]) => boolean = () => false,
): Promise<Heard> {
  const messages: Message[] = [];
  const dropped0 = parser.stats.droppedBytes + parser.stats.badChecksum;
  let lastByte: number | null = null;
  let wake: (() => void) | null = null;
  const off = port.onData((chunk) => {
    lastByte = performance.now();
    messages.push(...parser.feed(chunk));
    wake?.();
  });
  const started = performance.now();
  try {
    await port.write(frame);
    const written = performance.now();
    for (;;) {
      const limit = lastByte === null ? Math.min(startWithinMs, windowMs) : windowMs;
      const left = written + limit - performance.now();
      if (left <= 0 || enough(messages)) break;
      await Promise.race([
        sleep(left, signal),
        new Promise<void>((resolve) => {
          wake = resolve;
        }),
      ]);
      wake = null;
    }
    messages.push(...parser.finish());
  } finally {
    off();
  }
  return {
    messages,
    garbled: parser.stats.droppedBytes + parser.stats.badChecksum - dropped0,
    span: lastByte === null ? null : (lastByte as number) - started,
  };
}

/** Ms after a walk request's write by which its answer would have begun (discovery.py, walk_wait). */
export function walkWaitMs(rate: number, timing: Timing, spanMs: number | null): number {
  const char = wireTimeMs(1, rate);
  if (spanMs === null)
    return wireTimeMs(PING_LENGTH, rate) + WALK_RESPONSE_MS + 2 * timing.latencyMs + timing.marginMs + char;
  return Math.max(spanMs - wireTimeMs(PING_LENGTH, rate), 0) + 2 * char + timing.latencyMs;
}

/** Find controllers (see the module comment). Leaves the bus at its old rate. */
export async function discover(bus: Bus, options: DiscoverOptions = {}): Promise<Found[]> {
  const wanted = new Set(options.rates ?? BAUD_RATES);
  for (const rate of wanted)
    if (!BAUD_RATES.includes(rate))
      throw new RangeError(`${rate} bps is not a rate these controllers support; use one of ${BAUD_RATES.join(", ")}`);
  const rates = DISCOVERY_RATE_ORDER.filter((r) => wanted.has(r));
  const ids = options.ids ?? Array.from({ length: 255 }, (_, i) => i);
  const askLines = options.lines ?? true;
  const timing = bus.timing;
  const original = bus.baudRate;
  return bus.withPort(async (port, stop) => {
    const signal = options.signal === undefined ? stop : AbortSignal.any([stop, options.signal]);
    const found: Found[] = [];
    const progress = (rateIndex: number, walkingId: number | null, phase: "rates" | "lines" = "rates"): void =>
      options.onProgress?.({
        rate: port.baudRate,
        rateIndex,
        ratesTotal: rates.length,
        walkingId,
        found: found.map((f) => ({ ...f })),
        phase,
      });
    const firmwareOf = (id: number): Uint8Array => encode(make("request_firmware", id, {}));
    const fullWindow = (rate: number): number =>
      answerDeadlineMs(PING_LENGTH, FIRMWARE_ANSWER_LENGTH, rate, undefined, timing);
    const askFirmware = async (id: number, rate: number): Promise<Heard> => {
      const parser = new StreamParser();
      return exchange(port, firmwareOf(id), parser, fullWindow(rate), fullWindow(rate), signal, (m) =>
        m.some((x) => x.name === "firmware" && x.id === id),
      );
    };
    const setRate = async (rate: number): Promise<void> => {
      if (port.baudRate !== rate) await port.setBaudRate(rate);
    };
    try {
      for (const [rateIndex, rate] of rates.entries()) {
        try {
          await setRate(rate);
        } catch (error) {
          options.onRateSkipped?.(rate, `${rate} bps: the port refused it (${(error as Error).message})`);
          continue;
        }
        progress(rateIndex, null);
        let garbled = true;
        let span: number | null = null;
        const heard = new Set<number>();
        const first = found.length;
        if (options.ids === undefined) {
          const window = answerDeadlineMs(PING_LENGTH, PING_LENGTH, rate, HOST_TIMING.maxResponseTimeUs, timing);
          const begun = window - wireTimeMs(PING_LENGTH - 1, rate);
          const answer = await exchange(
            port,
            buildFrame(BROADCAST_ID, 0xa0, new Uint8Array()),
            new StreamParser(),
            window,
            begun,
            signal,
          );
          for (const m of answer.messages)
            if (m.name === "ping" && !heard.has(m.id)) {
              heard.add(m.id);
              found.push({ id: m.id, baudrate: rate, firmware: null, collision: false, line: "unknown" });
            }
          garbled = answer.garbled > 0;
          span = answer.span;
        }
        if (garbled) {
          const startWithin = walkWaitMs(rate, timing, span);
          const suspects: number[] = [];
          for (const id of ids) {
            if (heard.has(id)) continue;
            progress(rateIndex, id);
            const answer = await exchange(
              port,
              firmwareOf(id),
              new StreamParser(),
              fullWindow(rate),
              startWithin,
              signal,
              (m) => m.some((x) => x.name === "firmware" && x.id === id),
            );
            for (const m of answer.messages)
              if (m.name === "firmware" && !heard.has(m.id)) {
                heard.add(m.id);
                found.push({
                  id: m.id,
                  baudrate: rate,
                  firmware: (m as unknown as { version: number }).version,
                  collision: false,
                  line: "unknown",
                });
              }
            if (answer.garbled > 0 && !heard.has(id)) suspects.push(id);
          }
          for (const id of suspects) {
            // asked alone once the line is quiet: garbled again is a collision, silence clears it
            await sleep(fullWindow(rate), signal);
            const again = await askFirmware(id, rate);
            const answer = again.messages.find((m) => m.name === "firmware" && m.id === id);
            if (answer !== undefined && !heard.has(id)) {
              heard.add(id);
              const version = (answer as unknown as { version: number }).version;
              found.push({ id, baudrate: rate, firmware: version, collision: false, line: "unknown" });
            } else if (again.garbled > 0 && !heard.has(id)) {
              heard.add(id);
              found.push({ id, baudrate: rate, firmware: null, collision: true, line: "unknown" });
            }
          }
        }
        found.splice(first, found.length - first, ...found.slice(first).sort((a, b) => a.id - b.id));
      }
      for (const f of found) {
        if (f.collision || (f.firmware !== null && !askLines)) continue;
        progress(rates.length - 1, f.id, "lines");
        await setRate(f.baudrate);
        for (let attempt = 0; f.firmware === null && attempt <= HOST_TIMING.retries; attempt++) {
          const answer = (await askFirmware(f.id, f.baudrate)).messages.find(
            (m) => m.name === "firmware" && m.id === f.id,
          );
          if (answer !== undefined) f.firmware = (answer as unknown as { version: number }).version;
        }
        if (askLines) f.line = await detectLine(port, f.id, timing, signal);
      }
      progress(rates.length - 1, null, "lines");
      return found;
    } finally {
      if (port.baudRate !== original) await port.setBaudRate(original).catch(() => undefined);
    }
  }, options.signal);
}

/** One controller's line by the rule: the first of the questions answered in its line's own layout. */
async function detectLine(port: BytePort, id: number, timing: Timing, signal: AbortSignal): Promise<string> {
  for (const [line, request] of LINE_RULE) {
    const spec = lineMessageSpec(line, request);
    const answerSpec = lineMessageSpec(line, spec.answer as string);
    const window = answerDeadlineMs(spec.size + 4, answerSpec.size + 4, port.baudRate, undefined, timing);
    for (let attempt = 0; attempt <= HOST_TIMING.retries; attempt++) {
      const heard = await exchange(
        port,
        encodeIn(line, makeIn(line, request, id, {})),
        lineParser(line),
        window,
        window,
        signal,
        (m) => m.some((x) => x.id === id && x.name === answerSpec.name),
      );
      if (heard.messages.some((m) => m.id === id && m.name === answerSpec.name)) return line;
      if (heard.garbled === 0 && heard.span !== null) break; // a clean answer of another layout: not this line
    }
  }
  return "unknown";
}

/**
 * A command of a product line other than MC (the bus client speaks MC's table): written in
 * turn with every other call, never before a stop sent earlier. E.g. the E-STOP's control off
 * to an RSA (its mode 0A, not MC's 0C).
 */
export function tellInLine(
  bus: Bus,
  line: string,
  name: string,
  id: number,
  fields: Readonly<Record<string, unknown>> = {},
): Promise<void> {
  const frame = encodeIn(line, makeIn(line, name, id, fields));
  return bus.withPort((port) => port.write(frame));
}

/** A request of a product line, its answer in that line's layout; null if none came (after the retries). */
export function askInLine(
  bus: Bus,
  line: string,
  name: string,
  id: number,
  fields: Readonly<Record<string, unknown>> = {},
): Promise<Message | null> {
  const spec = lineMessageSpec(line, name);
  const answerSpec = lineMessageSpec(line, spec.answer as string);
  const frame = encodeIn(line, makeIn(line, name, id, fields));
  return bus.withPort(async (port, stop) => {
    const window = answerDeadlineMs(spec.size + 4, answerSpec.size + 4, port.baudRate, undefined, bus.timing);
    const mine = (m: Message): boolean => m.id === id && m.name === answerSpec.name;
    for (let attempt = 0; attempt <= bus.retries; attempt++) {
      const heard = await exchange(port, frame, lineParser(line), window, window, stop, (m) => m.some(mine));
      const answer = heard.messages.find(mine);
      if (answer !== undefined) return answer;
    }
    return null;
  });
}
