/**
 * The bus client: one host, half-duplex, one transaction at a time.
 *
 * Rules (the same as the Python library's):
 * - Commands (modes 01-10) are sent without waiting and are never repeated by the
 *   client: a repeated relative move would move twice, so a retry is the caller's call.
 * - A request waits for the answer whose ID is the request's and whose mode is the
 *   request's + 0x30. The adapter's echo of our own request is skipped; bytes that
 *   arrived between transactions (stale) are discarded before a request is sent;
 *   noise is skipped by the stream parser.
 * - The timeout comes from the wire (see timing.ts); a request with no answer is
 *   sent again up to `retries` more times, then a typed error says why it failed.
 */
import { answerName, encode, messageSpec, type AnswerMessageOf, type Message, type MessageOf } from "../codec.js";
import type { AnswerOf } from "../generated/messages.js";
import { BAUD_RATES } from "../generated/tables.js";
import { StreamParser } from "../parser.js";
import { BusClosedError, BusError, CorruptedAnswerError, NoAnswerError, UnexpectedAnswerError } from "./errors.js";
import type { BytePort } from "./port.js";
import { answerTimeoutMs, DEFAULT_ADAPTER_LATENCY_MS } from "./timing.js";

/** Requests with an answer (all of them: every request is answered). */
type RequestName = keyof AnswerOf;

export interface BusOptions {
  /** Extra time the adapter and OS add before received bytes reach us (default 20 ms). */
  adapterLatencyMs?: number;
  /** The controllers' response time in microseconds, if set above the default 100 us. */
  responseTimeUs?: number;
  /** How many times a request is sent again after no (valid) answer (default 2). */
  retries?: number;
  /** Every frame sent and received, decoded: for a traffic log or a raw view. */
  onTraffic?: (event: TrafficEvent) => void;
}

export interface TrafficEvent {
  direction: "tx" | "rx";
  /** milliseconds since the bus was opened */
  time: number;
  message: Message;
}

export interface BusStats {
  requests: number;
  commands: number;
  retries: number;
  /** our own request, echoed back by the adapter */
  echoes: number;
  /** frames received outside a transaction (discarded) */
  staleFrames: number;
  /** frames received during a transaction that were not its answer */
  unexpectedFrames: number;
  noAnswer: number;
  corrupted: number;
}

interface Pending {
  request: Message;
  answer: string;
  unexpected: Message[];
  resolve: (answer: Message) => void;
}

/** Request/answer client over any BytePort. Every method is safe to call concurrently: calls queue. */
export class Bus {
  readonly stats: BusStats = { requests: 0, commands: 0, retries: 0, echoes: 0, staleFrames: 0, unexpectedFrames: 0, noAnswer: 0, corrupted: 0 };
  readonly parser = new StreamParser();
  adapterLatencyMs: number;
  responseTimeUs: number;
  retries: number;
  private readonly onTraffic: ((event: TrafficEvent) => void) | undefined;
  private readonly opened = Date.now();
  private readonly unsubscribe: Array<() => void>;
  private queue: Promise<unknown> = Promise.resolve();
  private pending: Pending | null = null;
  private closed: Error | null = null;

  constructor(
    readonly port: BytePort,
    options: BusOptions = {},
  ) {
    this.adapterLatencyMs = nonNegative("adapterLatencyMs", options.adapterLatencyMs ?? DEFAULT_ADAPTER_LATENCY_MS);
    this.responseTimeUs = nonNegative("responseTimeUs", options.responseTimeUs ?? 100);
    this.retries = nonNegative("retries", options.retries ?? 2);
    this.onTraffic = options.onTraffic;
    this.unsubscribe = [
      port.onData((chunk) => this.received(chunk)),
      port.onError((error) => {
        this.closed = error;
      }),
    ];
  }

  get baudRate(): number {
    return this.port.baudRate;
  }

  /** Switch the host's rate (one of the 18 the controllers support). */
  setBaudRate(rate: number): Promise<void> {
    if (!BAUD_RATES.includes(rate)) {
      return Promise.reject(new RangeError(`${rate} bps is not a rate these controllers support; use one of ${BAUD_RATES.join(", ")}`));
    }
    return this.exclusive(() => this.port.setBaudRate(rate));
  }

  /** Send a command (modes 01-10) once, without waiting: controllers never answer commands. */
  send(command: Message): Promise<void> {
    const spec = messageSpec(command.name);
    if (spec.kind !== "command") {
      return Promise.reject(new BusError(`${command.name} is a ${spec.kind}, not a command; use request() for feedback requests`));
    }
    let frame: Uint8Array;
    try {
      frame = encode(command);
    } catch (err) {
      return Promise.reject(err);
    }
    return this.exclusive(async () => {
      this.stats.commands += 1;
      await this.transmit(command, frame);
    });
  }

  /** Send a request and return its answer; see the class comment for timeouts and retries. */
  request<N extends RequestName>(request: MessageOf<N>, options?: { retries?: number }): Promise<AnswerMessageOf<N>>;
  request(request: Message, options?: { retries?: number }): Promise<Message>;
  request(request: Message, options: { retries?: number } = {}): Promise<Message> {
    const spec = messageSpec(request.name);
    if (spec.kind !== "request") {
      return Promise.reject(new BusError(`${request.name} is a ${spec.kind}, not a request; commands are sent with send() and never answered`));
    }
    let frame: Uint8Array;
    try {
      frame = encode(request); // also refuses ID 255: requests are never broadcast
    } catch (err) {
      return Promise.reject(err);
    }
    const answer = answerName(request.name);
    const retries = nonNegative("retries", options.retries ?? this.retries);
    return this.exclusive(() => this.transact(request, frame, answer, retries));
  }

  /** The timeout of one attempt of `request` at the current rate. */
  timeoutMs(request: Message): number {
    return answerTimeoutMs({
      requestBytes: messageSpec(request.name).size + 4,
      answerBytes: messageSpec(answerName(request.name)).size + 4,
      baudRate: this.port.baudRate,
      responseTimeUs: this.responseTimeUs,
      adapterLatencyMs: this.adapterLatencyMs,
    });
  }

  /** Stop listening and close the port; queued calls fail with BusClosedError. */
  async close(): Promise<void> {
    if (this.closed === null) this.closed = new BusClosedError("the bus is closed");
    for (const unsubscribe of this.unsubscribe) unsubscribe();
    await this.port.close();
  }

  private async transact(request: Message, frame: Uint8Array, answer: string, retries: number): Promise<Message> {
    this.stats.requests += 1;
    const timeout = this.timeoutMs(request);
    let corrupted = { dropped: 0, badChecksum: 0 };
    let unexpected: Message[] = [];
    for (let attempt = 0; attempt <= retries; attempt++) {
      if (attempt > 0) this.stats.retries += 1;
      this.parser.clear(); // stale partial bytes from before this request
      const before = { ...this.parser.stats };
      const pending: Pending = { request, answer, unexpected: [], resolve: () => undefined };
      const got = new Promise<Message | null>((resolve) => {
        const timer = setTimeout(() => resolve(null), timeout);
        pending.resolve = (message) => {
          clearTimeout(timer);
          resolve(message);
        };
      });
      this.pending = pending;
      try {
        await this.transmit(request, frame);
        const message = await got;
        if (message !== null) return message;
      } finally {
        this.pending = null;
      }
      this.parser.clear(); // a partial frame left at the timeout counts as unusable bytes
      const dropped = this.parser.stats.droppedBytes - before.droppedBytes;
      const badChecksum = this.parser.stats.badChecksum - before.badChecksum;
      if (dropped > 0 || badChecksum > 0) corrupted = { dropped: corrupted.dropped + dropped, badChecksum: corrupted.badChecksum + badChecksum };
      unexpected = unexpected.concat(pending.unexpected);
    }
    if (corrupted.dropped > 0 || corrupted.badChecksum > 0) {
      this.stats.corrupted += 1;
      throw new CorruptedAnswerError(request, retries + 1, corrupted.dropped, corrupted.badChecksum);
    }
    if (unexpected.length > 0) throw new UnexpectedAnswerError(request, unexpected);
    this.stats.noAnswer += 1;
    throw new NoAnswerError(request, retries + 1, timeout, this.port.baudRate);
  }

  private async transmit(message: Message, frame: Uint8Array): Promise<void> {
    if (this.closed !== null) throw this.closed instanceof BusError ? this.closed : new BusClosedError(`the port failed: ${this.closed.message}`, { cause: this.closed });
    this.onTraffic?.({ direction: "tx", time: Date.now() - this.opened, message });
    await this.port.write(frame);
  }

  private received(chunk: Uint8Array): void {
    for (const message of this.parser.feed(chunk)) {
      this.onTraffic?.({ direction: "rx", time: Date.now() - this.opened, message });
      const pending = this.pending;
      if (pending === null) {
        this.stats.staleFrames += 1;
      } else if (message.id === pending.request.id && message.name === pending.answer) {
        pending.resolve(message);
      } else if (message.id === pending.request.id && message.name === pending.request.name) {
        this.stats.echoes += 1;
      } else {
        this.stats.unexpectedFrames += 1;
        pending.unexpected.push(message);
      }
    }
  }

  /** Run `task` after every earlier call has finished (half-duplex: one transaction at a time). */
  private exclusive<T>(task: () => Promise<T>): Promise<T> {
    const run = this.queue.then(() => {
      if (this.closed !== null) throw this.closed instanceof BusError ? this.closed : new BusClosedError(`the port failed: ${this.closed.message}`);
      return task();
    });
    this.queue = run.catch(() => undefined);
    return run;
  }
}

function nonNegative(name: string, value: number): number {
  if (!Number.isFinite(value) || value < 0) throw new RangeError(`bus option ${name} = ${value}: must be a finite number >= 0`);
  return value;
}
