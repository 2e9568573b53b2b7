/**
 * A BytePort that survives its port going away (as Python's `Bus.open(url, reconnect=True)`,
 * docs/library.md "Reconnect"): the loss is noticed once and reported once (`onPortEvent`), the
 * port is reopened with backoff (50 ms, then every 100 ms: one open attempt each, no busy loop),
 * and while it is down every write fails at once with `PortLost`, so nothing asked meanwhile is
 * sent later. Frames registered with `onReturn` (a stop that could not go out) are written first
 * on the reopened port, before anything else.
 *
 *   const port = new ReconnectingPort((rate) => NodeSerialPort.open("/dev/serial/by-id/usb-...", rate), 115200);
 *   await port.start();
 *   const bus = new Bus(port);
 *
 * Give the `/dev/serial/by-id/...` name of a USB adapter: it is the same after the adapter
 * re-enumerates under another ttyUSBn.
 */
import { PortError } from "./errors.js";
import { type BytePort, Listeners } from "./port.js";

/** The port is lost and being reopened; nothing was sent. */
export class PortLost extends PortError {
  override name = "PortLost";
}

export interface PortEvent {
  kind: "lost" | "back";
  /** One line for people. */
  text: string;
  /** Milliseconds the port was down (on "back"). */
  downMs?: number;
  /** Keys of the onReturn frames written first (on "back"). */
  sentFirst?: string[];
}

export type PortOpener = (baudRate: number) => Promise<BytePort>;

export interface ReconnectOptions {
  /** First reopen attempt after a loss, ms (default 50). */
  firstRetryMs?: number;
  /** Longest pause between attempts, ms (default 100). */
  maxRetryMs?: number;
  /** A name for messages (the path). */
  name?: string;
  now?: () => number;
}

export class ReconnectingPort implements BytePort {
  private inner: BytePort | null = null;
  private rate: number;
  private unsubscribe: (() => void)[] = [];
  private readonly data = new Listeners<Uint8Array>();
  private readonly errors = new Listeners<Error>();
  private readonly events = new Listeners<PortEvent>();
  private readonly owed = new Map<string, Uint8Array>();
  private timer: ReturnType<typeof setTimeout> | null = null;
  private closed = false;
  private lostAt: number | null = null;
  private cause = "";
  private readonly name: string;
  private readonly now: () => number;
  /** Times the port was lost, and came back. */
  losses = 0;
  returns = 0;
  /** Why the latest reopen attempt failed. */
  lastAttemptError = "";

  constructor(
    private readonly open: PortOpener,
    baudRate: number,
    private readonly options: ReconnectOptions = {},
  ) {
    this.rate = baudRate;
    this.name = options.name ?? "the port";
    this.now = options.now ?? (() => performance.now());
  }

  /** Open the port the first time (fails as a plain open would). */
  async start(): Promise<this> {
    this.attach(await this.open(this.rate));
    return this;
  }

  get up(): boolean {
    return this.inner !== null;
  }

  get baudRate(): number {
    return this.rate;
  }

  onPortEvent(listener: (event: PortEvent) => void): () => void {
    return this.events.add(listener);
  }

  /** Frames written first when the port comes back, under `key`; null withdraws them. */
  onReturn(key: string, frames: Uint8Array | null): void {
    if (frames === null) this.owed.delete(key);
    else this.owed.set(key, frames.slice());
  }

  write(data: Uint8Array): Promise<void> {
    const inner = this.inner;
    if (inner === null) return Promise.reject(this.lostError());
    return inner.write(data).catch((error: unknown) => {
      this.lose(inner, error);
      throw this.lostError();
    });
  }

  onData(listener: (chunk: Uint8Array) => void): () => void {
    return this.data.add(listener);
  }

  /** Only losses are reported here, as PortLost (the bus fails its waiting call, and goes on). */
  onError(listener: (error: Error) => void): () => void {
    return this.errors.add(listener);
  }

  /** Kept while the port is down and used for the reopen. */
  async setBaudRate(rate: number): Promise<void> {
    this.rate = rate;
    const inner = this.inner;
    if (inner !== null) await inner.setBaudRate(rate);
  }

  async close(): Promise<void> {
    this.closed = true;
    if (this.timer !== null) clearTimeout(this.timer);
    const inner = this.detach();
    if (inner !== null) await inner.close();
  }

  private lostError(): PortLost {
    const down = this.lostAt === null ? 0 : (this.now() - this.lostAt) / 1000;
    return new PortLost(
      `${this.name} is lost (${this.cause}) and being reopened (down ${down.toFixed(1)} s); nothing was sent: try again when it is back`,
    );
  }

  private attach(inner: BytePort): void {
    this.inner = inner;
    this.unsubscribe = [
      inner.onData((chunk) => this.data.emit(chunk)),
      inner.onError((error) => this.lose(inner, error)),
    ];
  }

  private detach(): BytePort | null {
    for (const stop of this.unsubscribe) stop();
    this.unsubscribe = [];
    const inner = this.inner;
    this.inner = null;
    return inner;
  }

  private lose(inner: BytePort, error: unknown): void {
    if (this.inner !== inner || this.closed) return; // said once
    this.detach();
    inner.close().catch(() => undefined);
    this.lostAt = this.now();
    this.cause = error instanceof Error ? error.message : String(error);
    this.losses += 1;
    const text = `${this.name} lost (${this.cause}); reopening it in the background`;
    this.events.emit({ kind: "lost", text });
    this.errors.emit(this.lostError());
    this.retry(this.options.firstRetryMs ?? 50);
  }

  private retry(delay: number): void {
    if (this.closed) return;
    this.timer = setTimeout(() => {
      this.timer = null;
      void this.reopen(Math.min(delay * 2, this.options.maxRetryMs ?? 100));
    }, delay);
  }

  private async reopen(next: number): Promise<void> {
    let port: BytePort;
    try {
      port = await this.open(this.rate);
    } catch (error) {
      this.lastAttemptError = error instanceof Error ? error.message : String(error);
      this.retry(next);
      return;
    }
    if (this.closed) {
      await port.close();
      return;
    }
    const sent: string[] = [];
    try {
      for (const key of [...this.owed.keys()].sort()) {
        await port.write(this.owed.get(key) as Uint8Array);
        sent.push(key);
      }
    } catch (error) {
      this.lastAttemptError = error instanceof Error ? error.message : String(error);
      await port.close().catch(() => undefined);
      this.retry(next);
      return;
    }
    for (const key of sent) this.owed.delete(key);
    this.attach(port);
    this.returns += 1;
    const downMs = this.now() - (this.lostAt ?? this.now());
    this.lostAt = null;
    const first = sent.length ? `; sent first: ${sent.join(", ")}` : "";
    this.events.emit({
      kind: "back",
      text: `${this.name} is back after ${(downMs / 1000).toFixed(1)} s${first}`,
      downMs,
      sentFirst: sent,
    });
  }
}
