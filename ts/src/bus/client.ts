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
 * - The timeout comes from the wire (see timing.ts); a request with no valid answer is
 *   sent again up to `retries` more times (after a short pause), then a typed error says
 *   why the last attempt failed: other frames (unexpected) before broken bytes
 *   (corrupted) before silence (no answer).
 */
import { answerName, encode, messageSpec, type AnswerMessageOf, type Message, type MessageOf } from "../codec.js";
import type { AnswerOf } from "../generated/messages.js";
import { BAUD_RATES } from "../generated/tables.js";
import { StreamParser } from "../parser.js";
import { BusClosedError, BusError, CorruptedAnswerError, NoAnswerError, UnexpectedAnswerError } from "./errors.js";
import type { BytePort } from "./port.js";
import { answerDeadlineMs, DEFAULT_TIMING, type Timing } from "./timing.js";

/** Requests with an answer (all of them: every request is answered). */
type RequestName = keyof AnswerOf;

export interface BusOptions {
  /** Latency, margin and the response time assumed for unknown controllers (timing.ts). */
  timing?: Partial<Timing>;
  /** Known response-time settings (us) per controller ID; the others are assumed the largest. */
  responseTimesUs?: Record<number, number>;
  /** How many times a request is sent again after no (valid) answer (default 2). */
  retries?: number;
  /** Pause before a retry, ms (default 5). */
  retryPauseMs?: number;
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
  timing: Timing;
  /** Known response-time settings (us) per controller ID (Motor keeps it up to date). */
  readonly responseTimesUs: Map<number, number>;
  retries: number;
  retryPauseMs: number;
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
    const timing = { ...DEFAULT_TIMING, ...options.timing };
    for (const [key, value] of Object.entries(timing)) nonNegative(`timing.${key}`, value);
    this.timing = timing;
    this.responseTimesUs = new Map(Object.entries(options.responseTimesUs ?? {}).map(([id, us]) => [Number(id), nonNegative("responseTimesUs", us)]));
    this.retries = nonNegative("retries", options.retries ?? 2);
    this.retryPauseMs = nonNegative("retryPauseMs", options.retryPauseMs ?? 5);
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

  /** Send commands (modes 01-10) back to back in one write, once, without waiting: controllers never answer them. */
  send(...commands: Message[]): Promise<void> {
    const frames: Uint8Array[] = [];
    try {
      for (const command of commands) {
        const spec = messageSpec(command.name);
        if (spec.kind !== "command") throw new BusError(`${command.name} is a ${spec.kind}, not a command; use request() for feedback requests`);
        frames.push(encode(command));
      }
    } catch (err) {
      return Promise.reject(err);
    }
    const bytes = new Uint8Array(frames.reduce((n, f) => n + f.length, 0));
    frames.reduce((at, f) => (bytes.set(f, at), at + f.length), 0);
    return this.exclusive(async () => {
      this.stats.commands += commands.length;
      if (bytes.length > 0) await this.transmit(commands, bytes);
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

  /** The timeout of one attempt of `request` at the current rate (from the end of the write). */
  timeoutMs(request: Message): number {
    return answerDeadlineMs(
      messageSpec(request.name).size + 4,
      messageSpec(answerName(request.name)).size + 4,
      this.port.baudRate,
      this.responseTimesUs.get(request.id),
      this.timing,
    );
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
    let failure: Error = new NoAnswerError(request, retries + 1, timeout, this.port.baudRate);
    for (let attempt = 0; attempt <= retries; attempt++) {
      if (attempt > 0) {
        this.stats.retries += 1;
        await sleep(this.retryPauseMs);
      }
      this.parser.clear(); // stale partial bytes from before this request
      const before = { ...this.parser.stats };
      let settle: (message: Message | null) => void = () => undefined;
      const got = new Promise<Message | null>((resolve) => (settle = resolve));
      const pending: Pending = { request, answer, unexpected: [], resolve: (message) => settle(message) };
      this.pending = pending; // before the write: a fast answer may come before write() resolves
      let timer: ReturnType<typeof setTimeout> | undefined;
      try {
        await this.transmit([request], frame);
        timer = setTimeout(() => settle(null), timeout); // the deadline counts from the end of the write
        const message = await got;
        if (message !== null) return message;
      } finally {
        clearTimeout(timer);
        this.pending = null;
      }
      this.parser.clear(); // a partial frame left at the timeout counts as unusable bytes
      const dropped = this.parser.stats.droppedBytes - before.droppedBytes;
      const badChecksum = this.parser.stats.badChecksum - before.badChecksum;
      // the last attempt's failure is reported, in the Python library's order of precedence
      if (pending.unexpected.length > 0) failure = new UnexpectedAnswerError(request, pending.unexpected);
      else if (dropped > 0 || badChecksum > 0) failure = new CorruptedAnswerError(request, attempt + 1, dropped, badChecksum);
      else failure = new NoAnswerError(request, attempt + 1, timeout, this.port.baudRate);
    }
    if (failure instanceof CorruptedAnswerError) this.stats.corrupted += 1;
    if (failure instanceof NoAnswerError) this.stats.noAnswer += 1;
    throw failure;
  }

  private async transmit(messages: Message[], frame: Uint8Array): Promise<void> {
    if (this.closed !== null) throw this.closed instanceof BusError ? this.closed : new BusClosedError(`the port failed: ${this.closed.message}`, { cause: this.closed });
    for (const message of messages) this.onTraffic?.({ direction: "tx", time: Date.now() - this.opened, message });
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

const sleep = (ms: number): Promise<void> => new Promise((resolve) => setTimeout(resolve, ms));

function nonNegative(name: string, value: number): number {
  if (!Number.isFinite(value) || value < 0) throw new RangeError(`bus option ${name} = ${value}: must be a finite number >= 0`);
  return value;
}
