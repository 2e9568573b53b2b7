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
 * - Busy windows (docs/protocol.md, Busy window): a command in EEPROM_WRITES (spec/host.json)
 *   makes its ID busy for the ID's window after the write has gone out (set_id: the new ID too;
 *   factory_reset: ID 0 too; a broadcast: every ID, for the largest window). No frame goes to
 *   a busy ID before its window ends: the client waits it out. Silence from a request sent
 *   within one more window after that is a ControllerBusyError, not a wiring problem.
 * - Failures reach the call (docs/drivers.md, "The TypeScript client"): a port that fails
 *   while a call waits for its answer fails that call at once; `request(..., { signal })`
 *   ends the call when the signal aborts (before its turn, in a busy wait or waiting for
 *   the answer) and frees the queue.
 * - Stale answers (docs/protocol.md, Stale answers: the Python library's fence rule, the same
 *   assumptions A1-A3 and parameters). Every request sent leaves an owed entry for its ID (its
 *   answer class, in send order) until an answer settles it or `sent + deadline + late` passes
 *   (spec/host.json `timing.late_answer_s`). An answer of class C settles the earliest C entry of
 *   its ID and every entry before it (A1: answers come in order); a byte-identical repeat of the
 *   last answer seen from an ID settles nothing (A2: it may be a copy). A request of class C goes
 *   to an ID only when that ID owes no C answer to an earlier call: otherwise a fence (a ping; for
 *   a ping, a firmware request) goes first, and its answer settles everything asked before it.
 *   Two unanswered fences fall back to listening until the owed C entries expire (A3). Before
 *   asking an ID the same thing it has just answered, the client leaves two character times, so a
 *   copy has arrived and is dropped before the request. A late answer to an earlier attempt of
 *   the same call is that call's answer. A rate change forgets what is owed. The shared cases:
 *   spec/vectors/stale-answers.json (run against this client and the Python one).
 * - The emergency stop (`emergency()`) jumps the queue: every queued call fails with
 *   CancelledError without touching the port, the call in progress stops waiting, and the stop's
 *   frames are written next, ahead of anything sent after it.
 */
import { type AnswerMessageOf, answerName, encode, type Message, type MessageOf, make, messageSpec } from "../codec.js";
import { buildFrame } from "../frame.js";
import { DEFAULT_PROFILE, EEPROM_WRITES, HOST_PROFILES, HOST_TIMING } from "../generated/host.js";
import type { AnswerOf } from "../generated/messages.js";
import { BAUD_RATES, BROADCAST_ID } from "../generated/tables.js";
import { StreamParser } from "../parser.js";
import {
  BusClosedError,
  BusError,
  CancelledError,
  ControllerBusyError,
  CorruptedAnswerError,
  NoAnswerError,
  UnexpectedAnswerError,
} from "./errors.js";
import type { BytePort } from "./port.js";
import { answerDeadlineMs, DEFAULT_TIMING, type Timing, wireTimeMs } from "./timing.js";

/** Requests with an answer (all of them: every request is answered). */
type RequestName = keyof AnswerOf;

export interface BusOptions {
  /** Latency, margin and the response time assumed for unknown controllers (timing.ts). */
  timing?: Partial<Timing>;
  /** Known response-time settings (us) per controller ID; the others are assumed the largest. */
  responseTimesUs?: Record<number, number>;
  /** How many times a request is sent again after no (valid) answer (default from spec/host.json: 2). */
  retries?: number;
  /** Pause before a retry, ms (default from spec/host.json: 5). */
  retryPauseMs?: number;
  /** EEPROM busy window for every ID of this bus, ms (default: each ID's product profile). */
  busyWindowMs?: number;
  /** How late an answer may be beyond its deadline and still be told apart, ms (default from spec/host.json: 100). */
  lateAnswerMs?: number;
  /** EEPROM busy window per ID, ms, ahead of busyWindowMs. */
  busyWindowsMs?: Record<number, number>;
  /** Product profile per ID (a key of HOST_PROFILES), for the default busy window; unknown IDs use "mc". */
  products?: Record<number, string>;
  /** The host clock in ms (default performance.now); tests may pass their own. */
  now?: () => number;
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
  /** frames no call took as its answer: late answers, copies, fence answers (Stale answers) */
  staleFrames: number;
  /** frames received during a transaction that were not its answer */
  unexpectedFrames: number;
  noAnswer: number;
  corrupted: number;
  /** frames held back until a controller's EEPROM busy window ended */
  busyWaits: number;
  /** requests that waited out answers their ID still owed after two unanswered fences (A3) */
  quietWaits: number;
  /** fence requests sent before a request whose ID still owed an answer of its class */
  fences: number;
  /** calls an emergency stop cancelled */
  cancelled: number;
}

interface Pending {
  request: Message;
  answer: string;
  /** a fence: done as soon as its ID owes no `fenceFor` answer (its answer is settled, not taken) */
  fenceFor?: string;
  /** a broadcast read: collects the answers of `ids` (see requestBroadcast) */
  broadcast?: BroadcastRead;
  unexpected: Message[];
  resolve: (answer: Message) => void;
  /** The port failed while the answer was awaited. */
  fail: (error: Error) => void;
}

/** A broadcast read in progress. */
interface BroadcastRead {
  /** the IDs, in the order they answer (staggered response times) */
  ids: readonly number[];
  /** IDs whose answer may be taken: those that owed no answer of the class before */
  wanted: ReadonlySet<number>;
  heard: Set<number>;
  settled: Set<number>;
  answers: Map<number, Message>;
}

export interface BroadcastOptions {
  /** How long the answers may take after the write, ms (default: the largest deadline among the IDs). */
  windowMs?: number;
  /** Ends the call when aborted: rejects with the signal's reason. */
  signal?: AbortSignal;
}

export interface RequestOptions {
  /** How many times the request is sent again after no (valid) answer (default: the bus's). */
  retries?: number;
  /** Ends the call when aborted (e.g. AbortSignal.timeout(ms)): rejects with the signal's reason. */
  signal?: AbortSignal;
}

/** Request/answer client over any BytePort. Every method is safe to call concurrently: calls queue. */
export class Bus {
  readonly stats: BusStats = {
    requests: 0,
    commands: 0,
    retries: 0,
    echoes: 0,
    staleFrames: 0,
    unexpectedFrames: 0,
    noAnswer: 0,
    corrupted: 0,
    busyWaits: 0,
    quietWaits: 0,
    fences: 0,
    cancelled: 0,
  };
  readonly parser = new StreamParser();
  timing: Timing;
  /** Known response-time settings (us) per controller ID (Motor keeps it up to date). */
  readonly responseTimesUs: Map<number, number>;
  retries: number;
  retryPauseMs: number;
  /** How late an answer may be beyond its deadline and still be told apart, ms. */
  lateAnswerMs: number;
  /** EEPROM busy window for every ID, ms (undefined: from each ID's product profile). */
  busyWindowMs: number | undefined;
  /** EEPROM busy window per ID, ms, ahead of busyWindowMs. */
  readonly busyWindowsMs: Map<number, number>;
  /** Product profile per ID (Motor declares it), for the default busy window. */
  readonly products: Map<number, string>;
  private readonly now: () => number;
  /** `now` is the host's own clock (performance.now), so a wait can be timed on it directly */
  private readonly realClock: boolean;
  /** host-clock time each ID's busy window ends (kept after it ends, to name the error right) */
  private readonly busyUntilMs = new Map<number, number>();
  private busyAllUntilMs = 0;
  private readonly onTraffic: ((event: TrafficEvent) => void) | undefined;
  private readonly opened = Date.now();
  private readonly unsubscribe: Array<() => void>;
  private queue: Promise<unknown> = Promise.resolve();
  /** the call now using the port (settled or not); the emergency stop goes right after it */
  private current: Promise<unknown> = Promise.resolve();
  /** bumped by every emergency stop: a call queued in an older epoch is cancelled at its turn */
  private epoch = 0;
  /** aborted by an emergency stop: ends the waits (busy, quiet, retry pause) of the call in progress */
  private stopSignal = new AbortController();
  /** answers each ID may still send, in the order their requests were sent (Stale answers) */
  private readonly owed = new Map<number, Owed[]>();
  /** per ID: the last answer seen from it (its bytes) and when (host clock), for the duplicate rule */
  private readonly lastSeen = new Map<number, { name: string; key: string; at: number }>();
  /** wakes a quiet period when an owed answer is settled */
  private quietWake: (() => void) | null = null;
  private pending: Pending | null = null;
  private closed: Error | null = null;
  /** withPort() has the port: received bytes are its own, not answers */
  private lent = false;

  constructor(
    readonly port: BytePort,
    options: BusOptions = {},
  ) {
    const timing = { ...DEFAULT_TIMING, ...options.timing };
    for (const [key, value] of Object.entries(timing)) nonNegative(`timing.${key}`, value);
    this.timing = timing;
    this.responseTimesUs = new Map(
      Object.entries(options.responseTimesUs ?? {}).map(([id, us]) => [Number(id), nonNegative("responseTimesUs", us)]),
    );
    this.retries = nonNegative("retries", options.retries ?? HOST_TIMING.retries);
    this.retryPauseMs = nonNegative("retryPauseMs", options.retryPauseMs ?? HOST_TIMING.retryPauseMs);
    this.lateAnswerMs = nonNegative("lateAnswerMs", options.lateAnswerMs ?? HOST_TIMING.lateAnswerMs);
    this.busyWindowMs =
      options.busyWindowMs === undefined ? undefined : nonNegative("busyWindowMs", options.busyWindowMs);
    this.busyWindowsMs = new Map(
      Object.entries(options.busyWindowsMs ?? {}).map(([id, ms]) => [
        deviceId("busyWindowsMs", id),
        nonNegative("busyWindowsMs", ms),
      ]),
    );
    this.products = new Map(
      Object.entries(options.products ?? {}).map(([id, product]) => [deviceId("products", id), knownProduct(product)]),
    );
    this.now = options.now ?? (() => performance.now());
    this.realClock = options.now === undefined;
    this.onTraffic = options.onTraffic;
    this.unsubscribe = [
      port.onData((chunk) => this.received(chunk)),
      port.onError((error) => {
        if (error.name !== "PortLost") this.closed = error; // a reconnecting port (reconnect.ts) comes back
        this.pending?.fail(portFailure(error)); // the call waiting for an answer fails now, not at its timeout
      }),
    ];
  }

  get baudRate(): number {
    return this.port.baudRate;
  }

  /** Switch the host's rate (one of the 18 the controllers support). */
  setBaudRate(rate: number): Promise<void> {
    if (!BAUD_RATES.includes(rate)) {
      return Promise.reject(
        new RangeError(`${rate} bps is not a rate these controllers support; use one of ${BAUD_RATES.join(", ")}`),
      );
    }
    return this.exclusive(async () => {
      await this.port.setBaudRate(rate);
      this.owed.clear(); // at another rate a late answer arrives as broken bytes, never as a frame
      this.lastSeen.clear();
    });
  }

  /** How many emergency stops this bus has sent: a multi-step operation started before one must not go on. */
  get stops(): number {
    return this.epoch;
  }

  /** Throws CancelledError if an emergency stop was sent since `stops` was read (Motor checks it between steps). */
  assertNoStopSince(stops: number): void {
    if (stops !== this.epoch) {
      this.stats.cancelled += 1;
      throw new CancelledError("cancelled by an emergency stop; the rest of this operation was not sent");
    }
  }

  /** How many answers an ID still owes (late answers the client will not take), and until when. */
  owedAnswers(id: number): { count: number; until: number } | undefined {
    this.forgetExpired(this.now());
    const owed = this.owed.get(id);
    return owed === undefined ? undefined : { count: owed.length, until: Math.max(...owed.map((o) => o.until)) };
  }

  /**
   * The emergency stop: send these commands (e.g. control off to 255) ahead of everything queued.
   * Every call queued before it fails with CancelledError without touching the port; a call in
   * progress stops waiting (its answer or a busy window) and fails the same way; the commands
   * are written next, without waiting for busy windows (a controller busy writing EEPROM ignores
   * them: verify by reading back and send again). Calls made after it run after it.
   *
   * It never waits behind a fence (Stale answers), and that is safe: its commands get no answers,
   * so nothing owed can be taken for them, and a fence or quiet period in progress is ended like
   * any other wait. The read-back that verifies the stop is itself a request, queued after the
   * stop: it is fenced like any other (its ID's owed entries survive the stop) or judged fresh by
   * the same rule, so a stale answer from before the stop can never confirm it.
   */
  emergency(...commands: Message[]): Promise<void> {
    const frames: Uint8Array[] = [];
    try {
      for (const command of commands) {
        if (messageSpec(command.name).kind !== "command") throw new BusError(`${command.name} is not a command`);
        frames.push(encode(command));
      }
    } catch (err) {
      return Promise.reject(err);
    }
    const bytes = new Uint8Array(frames.reduce((n, f) => n + f.length, 0));
    frames.reduce((at, f) => (bytes.set(f, at), at + f.length), 0);
    this.epoch += 1;
    const cancel = new CancelledError("cancelled by an emergency stop before it completed; nothing more was sent");
    this.stopSignal.abort(cancel);
    this.stopSignal = new AbortController();
    this.pending?.fail(cancel);
    const stop = this.current.then(async () => {
      if (this.closed !== null) throw portFailure(this.closed);
      this.stats.commands += commands.length;
      await this.transmit(commands, bytes);
      this.markBusy(commands, bytes.length);
    });
    this.current = stop.catch(() => undefined);
    const before = this.queue;
    this.queue = Promise.all([before, stop]).catch(() => undefined);
    return stop;
  }

  /** Send commands (modes 01-10) back to back in one write, once, without waiting: controllers never answer them. */
  send(...commands: Message[]): Promise<void> {
    const frames: Uint8Array[] = [];
    try {
      for (const command of commands) {
        const spec = messageSpec(command.name);
        if (spec.kind !== "command")
          throw new BusError(`${command.name} is a ${spec.kind}, not a command; use request() for feedback requests`);
        frames.push(encode(command));
      }
    } catch (err) {
      return Promise.reject(err);
    }
    const bytes = new Uint8Array(frames.reduce((n, f) => n + f.length, 0));
    frames.reduce((at, f) => (bytes.set(f, at), at + f.length), 0);
    return this.exclusive(async () => {
      this.stats.commands += commands.length;
      if (bytes.length === 0) return;
      await this.waitUntilFree(
        commands.map((command) => command.id),
        this.stopSignal.signal,
      );
      await this.transmit(commands, bytes);
      this.markBusy(commands, bytes.length);
    });
  }

  /** Send a request and return its answer; see the class comment for timeouts and retries. */
  request<N extends RequestName>(request: MessageOf<N>, options?: RequestOptions): Promise<AnswerMessageOf<N>>;
  request(request: Message, options?: RequestOptions): Promise<Message>;
  request(request: Message, options: RequestOptions = {}): Promise<Message> {
    const spec = messageSpec(request.name);
    if (spec.kind !== "request") {
      return Promise.reject(
        new BusError(
          `${request.name} is a ${spec.kind}, not a request; commands are sent with send() and never answered`,
        ),
      );
    }
    let frame: Uint8Array;
    try {
      frame = encode(request); // also refuses ID 255: requests are never broadcast
    } catch (err) {
      return Promise.reject(err);
    }
    const answer = answerName(request.name);
    const retries = nonNegative("retries", options.retries ?? this.retries);
    const signal = options.signal;
    return this.exclusive(() => this.transact(request, frame, answer, retries, signal), signal);
  }

  /**
   * One request to every ID (ID 255), answered by each of `ids` in turn: give them staggered
   * response times, and `ids` in the order they answer. Outside the document's §17 (requests go
   * to 0-254), so use it where the controllers answer broadcast requests. Every ID's answer is
   * owed (docs/protocol.md, Stale answers): an ID that owed an answer of this class to an earlier
   * call is not taken from the broadcast (its answer only settles), and it and any ID whose answer
   * is missing are asked on their own, behind a fence. Once the last ID has answered, a missing
   * one is late and the window does not run out. Returns each ID's answer or its error, in order.
   */
  requestBroadcast<N extends RequestName>(
    request: N,
    ids: readonly number[],
    options?: BroadcastOptions,
  ): Promise<Map<number, AnswerMessageOf<N> | BusError>>;
  requestBroadcast(
    request: string,
    ids: readonly number[],
    options?: BroadcastOptions,
  ): Promise<Map<number, Message | BusError>>;
  requestBroadcast(
    request: string,
    ids: readonly number[],
    options: BroadcastOptions = {},
  ): Promise<Map<number, Message | BusError>> {
    let spec: ReturnType<typeof messageSpec>;
    try {
      spec = messageSpec(request);
      if (spec.kind !== "request") throw new BusError(`${request} is a ${spec.kind}, not a request`);
      for (const id of ids) deviceId("requestBroadcast ids", String(id));
      if (new Set(ids).size !== ids.length) throw new RangeError("requestBroadcast: an ID is listed twice");
      if (options.windowMs !== undefined) nonNegative("windowMs", options.windowMs);
    } catch (err) {
      return Promise.reject(err);
    }
    const signal = options.signal;
    return this.exclusive(() => this.broadcastRead(spec.name, spec.mode, ids, options.windowMs, signal), signal);
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

  /** The EEPROM busy window of an ID, ms (docs/protocol.md, Busy window, rule 2); 255: the largest. */
  windowMs(id: number): number {
    if (id === BROADCAST_ID) {
      const known = new Set([...this.busyWindowsMs.keys(), ...this.products.keys()]);
      return Math.max(this.defaultWindowMs(), ...[...known].map((known) => this.windowMs(known)));
    }
    const own = this.busyWindowsMs.get(id);
    if (own !== undefined) return own;
    if (this.busyWindowMs !== undefined) return this.busyWindowMs;
    return profileWindowMs(this.products.get(id) ?? DEFAULT_PROFILE);
  }

  /** Host-clock time (ms, see BusOptions.now) an ID may be sent a frame again; 0: any time. 255: every ID. */
  busyUntil(id: number): number {
    if (id === BROADCAST_ID) return Math.max(this.busyAllUntilMs, ...this.busyUntilMs.values());
    return Math.max(this.busyAllUntilMs, this.busyUntilMs.get(id) ?? 0);
  }

  /**
   * Lend the port to a procedure that frames its own exchanges (discovery across rates, the
   * product-line questions): it runs in turn with every other call, the client ignores what
   * arrives meanwhile, and whatever was owed or seen is forgotten after it (the procedure may
   * have changed the rate). `stop` is aborted by an emergency stop sent meanwhile: the procedure
   * must end its waits then (the stop goes out right after it).
   */
  withPort<T>(task: (port: BytePort, stop: AbortSignal) => Promise<T>, signal?: AbortSignal): Promise<T> {
    return this.exclusive(async () => {
      this.lent = true;
      try {
        return await task(this.port, this.stopSignal.signal);
      } finally {
        this.lent = false;
        this.parser.clear();
        this.owed.clear();
        this.lastSeen.clear();
      }
    }, signal);
  }

  /** Stop listening and close the port; queued calls fail with BusClosedError. */
  async close(): Promise<void> {
    if (this.closed === null) this.closed = new BusClosedError("the bus is closed");
    for (const unsubscribe of this.unsubscribe) unsubscribe();
    await this.port.close();
  }

  private async transact(
    request: Message,
    frame: Uint8Array,
    answer: string,
    retries: number,
    signal?: AbortSignal,
  ): Promise<Message> {
    const stopped = this.stopSignal.signal;
    signal = signal === undefined ? stopped : AbortSignal.any([signal, stopped]);
    await this.fence(request.id, answer, signal);
    await this.duplicateGap(request.id, answer, signal);
    this.stats.requests += 1;
    const timeout = this.timeoutMs(request);
    let failure: Error | null = null; // built only when an attempt fails (an Error's stack costs a request's worth)
    let firstSentAt = 0;
    for (let attempt = 0; attempt <= retries; attempt++) {
      if (attempt > 0) {
        this.stats.retries += 1;
        await sleep(this.retryPauseMs, signal);
      }
      await this.waitUntilFree([request.id], signal);
      if (attempt === 0) firstSentAt = this.now();
      const droppedBefore = this.parser.stats.droppedBytes;
      const badChecksumBefore = this.parser.stats.badChecksum;
      const pending: Pending = { request, answer, unexpected: [], resolve: () => undefined, fail: () => undefined };
      const message = await this.exchange(pending, frame, timeout, signal);
      if (message !== null) return message;
      const dropped = this.parser.stats.droppedBytes - droppedBefore;
      const badChecksum = this.parser.stats.badChecksum - badChecksumBefore;
      // the last attempt's failure is reported, in the Python library's order of precedence
      if (pending.unexpected.length > 0) failure = new UnexpectedAnswerError(request, pending.unexpected);
      else if (dropped > 0 || badChecksum > 0)
        failure = new CorruptedAnswerError(request, attempt + 1, dropped, badChecksum);
      else if (this.recentlyBusy(request.id, firstSentAt)) {
        failure = new ControllerBusyError(request, attempt + 1, timeout, this.port.baudRate, this.windowMs(request.id));
      } else failure = new NoAnswerError(request, attempt + 1, timeout, this.port.baudRate);
    }
    failure ??= new NoAnswerError(request, retries + 1, timeout, this.port.baudRate);
    if (failure instanceof CorruptedAnswerError) this.stats.corrupted += 1;
    if (failure instanceof NoAnswerError) this.stats.noAnswer += 1;
    throw failure;
  }

  /**
   * One write and the wait for what it asks: `pending.answer` from its ID (taken and returned), or
   * for a fence, until its ID owes no `pending.fenceFor` answer any more (returns the fence's request).
   * null: the deadline passed first. The request is owed before the write: a fast answer may come
   * before write() resolves.
   */
  private async exchange(
    pending: Pending,
    frame: Uint8Array,
    timeout: number,
    signal: AbortSignal,
    owedEntries?: Owed[],
  ): Promise<Message | null> {
    const { request } = pending;
    let settle: (message: Message | null) => void = () => undefined;
    let fail: (error: unknown) => void = () => undefined;
    const got = new Promise<Message | null>((resolve, reject) => {
      settle = resolve;
      fail = reject;
    });
    pending.resolve = (message) => settle(message);
    pending.fail = fail;
    got.catch(() => undefined); // a failure before the write has resolved is taken up by `await got` below
    const abort = (): void => fail(signal.reason);
    signal.addEventListener("abort", abort);
    if (signal.aborted) abort();
    this.parser.clear(); // stale partial bytes from before this request (a copy's first bytes)
    const owed = owedEntries ?? [this.owe(request.id, pending.answer, Number.POSITIVE_INFINITY)];
    this.pending = pending;
    let timer: ReturnType<typeof setTimeout> | undefined;
    try {
      try {
        await this.transmit([request], frame);
      } finally {
        const until = this.now() + timeout + this.lateAnswerMs; // the deadline counts from the end of the write
        for (const entry of owed) entry.until = until;
      }
      timer = setTimeout(() => settle(null), timeout);
      return await got;
    } finally {
      clearTimeout(timer);
      signal.removeEventListener("abort", abort);
      if (this.pending === pending) this.pending = null;
      this.parser.clear(); // a partial frame left at the deadline counts as unusable bytes
    }
  }

  /** Owe an answer of class `answer` from `id`, after everything owed so far. */
  private owe(id: number, answer: string, until: number): Owed {
    const owed: Owed = { answer, until };
    const list = this.owed.get(id);
    if (list === undefined) this.owed.set(id, [owed]);
    else list.push(owed);
    return owed;
  }

  private forgetExpired(now: number): void {
    for (const [id, list] of this.owed) {
      const left = list.filter((o) => o.until > now);
      if (left.length > 0) this.owed.set(id, left);
      else this.owed.delete(id);
    }
  }

  /** May this ID still send an answer of this class to an earlier request? */
  private owes(id: number, answer: string): boolean {
    return this.owed.get(id)?.some((o) => o.answer === answer) ?? false;
  }

  /**
   * An answer came: it answers the earliest request still owed an answer of its class (or a later
   * one), and a controller answers in order (A1), so everything owed before that request has come
   * or never will. True if the ID owed such an answer.
   */
  private resolve(message: Message): boolean {
    const list = this.owed.get(message.id);
    if (list === undefined) return false;
    const index = list.findIndex((o) => o.answer === message.name);
    if (index < 0) return false;
    list.splice(0, index + 1);
    if (list.length === 0) this.owed.delete(message.id);
    this.quietWake?.();
    return true;
  }

  /** `message` is taken as the answer to a request of this call. */
  private take(message: Message): void {
    this.resolve(message);
    this.lastSeen.set(message.id, { name: message.name, key: frameKey(message), at: this.now() });
  }

  /**
   * A frame no call takes: counted stale; true if it was an answer some ID still owed, or a copy of
   * the last answer seen from that ID (a duplicate answers nothing, so it settles nothing).
   */
  private settleFrame(message: Message): boolean {
    this.stats.staleFrames += 1;
    return this.settle(message);
  }

  private settle(message: Message): boolean {
    if (messageSpec(message.name).kind === "request") return false;
    const last = this.lastSeen.get(message.id);
    const key = frameKey(message);
    this.lastSeen.set(message.id, { name: message.name, key, at: this.now() });
    if (last !== undefined && last.key === key) return true;
    return this.resolve(message);
  }

  private async broadcastRead(
    name: string,
    mode: number,
    ids: readonly number[],
    windowMs: number | undefined,
    signal?: AbortSignal,
  ): Promise<Map<number, Message | BusError>> {
    const stopped = this.stopSignal.signal;
    signal = signal === undefined ? stopped : AbortSignal.any([signal, stopped]);
    const answer = answerName(name);
    const out = new Map<number, Message | BusError>();
    if (ids.length === 0) return out;
    const window = windowMs ?? Math.max(...ids.map((id) => this.timeoutMs(make(name, id, {}) as Message)));
    this.forgetExpired(this.now());
    // an ID that may still send a late answer of this class cannot be told from its fresh one here
    const wanted = new Set(ids.filter((id) => !this.owes(id, answer)));
    for (const id of ids) await this.duplicateGap(id, answer, signal);
    await this.waitUntilFree([BROADCAST_ID], signal);
    this.stats.requests += 1;
    const read: BroadcastRead = { ids, wanted, heard: new Set(), settled: new Set(), answers: new Map() };
    const request = { name, id: BROADCAST_ID } as Message;
    const pending: Pending = {
      request,
      answer,
      broadcast: read,
      unexpected: [],
      resolve: () => undefined,
      fail: () => undefined,
    };
    // every ID's answer is owed until window + late after the write (exchange sets the time)
    const owed = ids.map((id) => this.owe(id, answer, Number.POSITIVE_INFINITY));
    await this.exchange(pending, buildFrame(BROADCAST_ID, mode, new Uint8Array()), window, signal, owed);
    for (const id of ids) {
      const got = read.answers.get(id);
      if (got !== undefined) {
        out.set(id, got);
        continue;
      }
      const single = make(name, id, {}) as Message;
      try {
        // asked on its own, behind a fence: its late answer to the broadcast cannot be taken
        out.set(id, await this.transact(single, encode(single), answer, this.retries, signal));
      } catch (err) {
        if (
          !(err instanceof NoAnswerError || err instanceof CorruptedAnswerError || err instanceof UnexpectedAnswerError)
        )
          throw err;
        out.set(id, err);
      }
    }
    return out;
  }

  /**
   * Before asking `id` for `answer` while it may still send a late one: ask it something whose
   * answer is of another class. Its answer proves (A1) that the late one came or never will; if no
   * fence is answered, wait the owed answers out (A3).
   */
  private async fence(id: number, answer: string, signal: AbortSignal): Promise<void> {
    this.forgetExpired(this.now());
    if (!this.owes(id, answer)) return;
    const fence = answer === "ping" ? make("request_firmware", id, {}) : make("request_ping", id, {});
    const frame = encode(fence);
    const timeout = this.timeoutMs(fence);
    for (let tries = 0; tries < FENCES; tries++) {
      this.stats.fences += 1;
      await this.waitUntilFree([id], signal);
      const pending: Pending = {
        request: fence,
        answer: answerName(fence.name),
        fenceFor: answer,
        unexpected: [],
        resolve: () => undefined,
        fail: () => undefined,
      };
      await this.exchange(pending, frame, timeout, signal);
      if (!this.owes(id, answer)) return;
    }
    await this.quiet(id, answer, signal);
  }

  /**
   * A copy of the last answer (a repeating adapter or line, A2) follows it back to back: before
   * asking the same ID the same thing again, let the copy's first bytes arrive, so the clear before
   * the request drops them (what is left of the copy can no longer form a frame).
   */
  private async duplicateGap(id: number, answer: string, signal: AbortSignal): Promise<void> {
    const last = this.lastSeen.get(id);
    if (last === undefined || last.name !== answer) return;
    const gap = last.at + 2 * wireTimeMs(1, this.port.baudRate);
    const now = this.now();
    if (now >= gap) return;
    // two characters are 20 us at 1 Mbps, but a timer waits at least 1 ms: a shorter wait on the
    // host's clock lets the event loop turn (received bytes are handled) until the time has passed
    if (this.realClock && gap - now < 1 && typeof setImmediate === "function") {
      while (performance.now() < gap) {
        signal.throwIfAborted();
        await new Promise<void>((resolve) => setImmediate(resolve));
      }
      signal.throwIfAborted();
    } else await sleep(gap - now, signal);
  }

  /** After two unanswered fences: listen until the `answer` entries `id` owes came or expired (A3). */
  private async quiet(id: number, answer: string, signal: AbortSignal): Promise<void> {
    let counted = false;
    for (;;) {
      const now = this.now();
      this.forgetExpired(now);
      const waiting = (this.owed.get(id) ?? []).filter((o) => o.answer === answer).map((o) => o.until);
      if (waiting.length === 0) return;
      if (!counted) {
        this.stats.quietWaits += 1;
        counted = true;
      }
      signal.throwIfAborted();
      await new Promise<void>((resolve, reject) => {
        const done = (): void => {
          clearTimeout(timer);
          signal.removeEventListener("abort", aborted);
          this.quietWake = null;
          resolve();
        };
        const aborted = (): void => {
          clearTimeout(timer);
          this.quietWake = null;
          reject(signal.reason);
        };
        const timer = setTimeout(done, Math.max(...waiting) - now);
        this.quietWake = done;
        signal.addEventListener("abort", aborted, { once: true });
      });
    }
  }

  private async transmit(messages: Message[], frame: Uint8Array): Promise<void> {
    if (this.closed !== null) throw portFailure(this.closed);
    for (const message of messages) this.onTraffic?.({ direction: "tx", time: Date.now() - this.opened, message });
    await this.port.write(frame);
  }

  private defaultWindowMs(): number {
    return this.busyWindowMs ?? profileWindowMs(DEFAULT_PROFILE);
  }

  /** Rule 4: no frame to an ID (255: to any) before its busy window has ended. */
  private async waitUntilFree(ids: readonly number[], signal?: AbortSignal): Promise<void> {
    const until = Math.max(0, ...ids.map((id) => this.busyUntil(id)));
    let now = this.now();
    if (until <= now) return;
    this.stats.busyWaits += 1;
    while (until > now) {
      await sleep(until - now, signal);
      now = this.now();
    }
  }

  /** Rule 3: after the write, every EEPROM-writing command makes its ID(s) busy. */
  private markBusy(commands: readonly Message[], frameBytes: number): void {
    const end = this.now() + wireTimeMs(frameBytes, this.port.baudRate) + this.timing.latencyMs;
    for (const command of commands) {
      if (!EEPROM_WRITES.includes(command.name)) continue;
      const ids = [command.id];
      if (command.name === "set_id") ids.push((command as MessageOf<"set_id">).new_id);
      else if (command.name === "factory_reset" && command.id !== BROADCAST_ID) ids.push(0); // it comes back as ID 0
      for (const id of ids) {
        const until = end + this.windowMs(id);
        if (id === BROADCAST_ID) this.busyAllUntilMs = Math.max(this.busyAllUntilMs, until);
        else this.busyUntilMs.set(id, Math.max(this.busyUntilMs.get(id) ?? 0, until));
      }
    }
  }

  /** Rule 6: was this request sent within one more window after the ID's busy window ended? */
  private recentlyBusy(id: number, sentAt: number): boolean {
    const until = this.busyUntil(id);
    return until > 0 && sentAt < until + this.windowMs(id);
  }

  private received(chunk: Uint8Array): void {
    if (this.lent) return; // a procedure of its own (withPort) reads these bytes
    for (const message of this.parser.feed(chunk)) {
      this.onTraffic?.({ direction: "rx", time: Date.now() - this.opened, message });
      const pending = this.pending;
      const isRequest = messageSpec(message.name).kind === "request";
      if (pending === null) {
        if (isRequest) this.stats.echoes += 1;
        else this.settleFrame(message);
      } else if (pending.broadcast !== undefined) {
        const read = pending.broadcast;
        if (isRequest) this.stats.echoes += 1;
        else if (message.name === pending.answer && read.wanted.has(message.id) && !read.heard.has(message.id)) {
          this.take(message);
          read.answers.set(message.id, message);
          read.heard.add(message.id);
        } else if (this.settleFrame(message) && read.ids.includes(message.id)) read.settled.add(message.id);
        const done = new Set([...read.heard, ...read.settled]);
        // every ID has answered, or the last to answer has: any missing answer is late (left owed)
        if (done.size >= read.ids.length || done.has(read.ids.at(-1) as number)) {
          this.pending = null;
          pending.resolve(message);
        }
      } else if (pending.fenceFor !== undefined) {
        if (message.id === pending.request.id && isRequest) this.stats.echoes += 1;
        else this.settleFrame(message);
        if (!this.owes(pending.request.id, pending.fenceFor)) {
          this.pending = null;
          pending.resolve(pending.request);
        }
      } else if (message.id === pending.request.id && message.name === pending.answer) {
        // the earliest attempt's answer, or a later one's: what is still owed stays owed
        this.take(message);
        this.pending = null; // a copy right behind it is judged by the duplicate rule, not taken
        pending.resolve(message);
      } else if (message.id === pending.request.id && message.name === pending.request.name) {
        this.stats.echoes += 1;
      } else if (this.settle(message)) {
        this.stats.staleFrames += 1;
      } else {
        // not an answer anyone owes: another controller or program is talking on the bus
        this.stats.unexpectedFrames += 1;
        pending.unexpected.push(message);
      }
    }
  }

  /** Run `task` after every earlier call has finished (half-duplex: one transaction at a time). */
  private exclusive<T>(task: () => Promise<T>, signal?: AbortSignal): Promise<T> {
    const epoch = this.epoch;
    const run = this.queue.then(() => {
      if (this.closed !== null) throw portFailure(this.closed);
      if (epoch !== this.epoch) {
        this.stats.cancelled += 1;
        throw new CancelledError("cancelled by an emergency stop before it was sent; nothing was sent");
      }
      signal?.throwIfAborted(); // aborted while queued: the port is not touched
      const current = task();
      this.current = current.catch(() => undefined);
      return current;
    });
    this.queue = run.catch(() => undefined);
    return run;
  }
}

/** fences tried before a request falls back to waiting out the answers its ID owes (as the Python client) */
const FENCES = 2;

/** An answer an ID may still send: of class `answer`; none is expected after `until` (host clock). */
interface Owed {
  answer: string;
  until: number;
}

/**
 * The frame a received message came in, as a key: a byte-identical repeat is a possible copy (A2).
 * Built from the name, ID and field values in frame order: a decoded message encodes back to its
 * frame and no other, so equal keys are equal frames (without encoding the frame again).
 */
function frameKey(message: Message): string {
  const values = message as unknown as Readonly<Record<string, number>>;
  let key = `${message.name} ${message.id}`;
  for (const field of messageSpec(message.name).fields) key += ` ${values[field.name]}`;
  return key;
}

/** Wait `ms`; an abort of `signal` ends the wait with the signal's reason. */
function sleep(ms: number, signal?: AbortSignal): Promise<void> {
  return new Promise((resolve, reject) => {
    if (signal?.aborted) {
      reject(signal.reason);
      return;
    }
    const done = (): void => {
      signal?.removeEventListener("abort", aborted);
      resolve();
    };
    const timer = setTimeout(done, ms);
    const aborted = (): void => {
      clearTimeout(timer);
      reject(signal?.reason);
    };
    signal?.addEventListener("abort", aborted, { once: true });
  });
}

/** The error every call gets once the port has failed (or the bus was closed). */
function portFailure(error: Error): BusError {
  return error instanceof BusError ? error : new BusClosedError(`the port failed: ${error.message}`, { cause: error });
}

function profileWindowMs(product: string): number {
  return (HOST_PROFILES[product] ?? HOST_PROFILES[DEFAULT_PROFILE])?.busyWindowMs ?? 0;
}

function deviceId(option: string, key: string): number {
  const id = Number(key);
  if (!Number.isInteger(id) || id < 0 || id > 254)
    throw new RangeError(`bus option ${option}: ID ${key} is not 0..254`);
  return id;
}

function knownProduct(product: string): string {
  if (!Object.hasOwn(HOST_PROFILES, product)) {
    throw new RangeError(`unknown product ${JSON.stringify(product)}; known: ${Object.keys(HOST_PROFILES).join(", ")}`);
  }
  return product;
}

function nonNegative(name: string, value: number): number {
  if (!Number.isFinite(value) || value < 0)
    throw new RangeError(`bus option ${name} = ${value}: must be a finite number >= 0`);
  return value;
}
