/** An in-memory BytePort for tests: records every write and answers through a scripted responder. */
import { type BytePort, Listeners } from "../src/bus/port.js";

/** Given the bytes the host wrote, what the "bus" sends back (nothing = silence). */
export type Responder = (written: Uint8Array, port: FakePort) => Uint8Array | readonly Uint8Array[] | null;

export class FakePort implements BytePort {
  readonly writes: Uint8Array[] = [];
  readonly rates: number[] = [];
  closed = false;
  private readonly data = new Listeners<Uint8Array>();
  private readonly errors = new Listeners<Error>();

  constructor(
    public responder: Responder = () => null,
    public baudRate = 115200,
  ) {}

  write(data: Uint8Array): Promise<void> {
    if (this.closed) return Promise.reject(new Error("closed"));
    this.writes.push(data.slice());
    const reply = this.responder(data.slice(), this);
    if (reply !== null) {
      const chunks = reply instanceof Uint8Array ? [reply] : reply;
      // deliver later, as a real line would, one chunk per macrotask
      chunks.forEach((chunk, i) => {
        setTimeout(() => this.inject(chunk), i);
      });
    }
    return Promise.resolve();
  }

  /** Bytes arriving from the bus now. */
  inject(bytes: Uint8Array): void {
    this.data.emit(bytes);
  }

  fail(error: Error): void {
    this.errors.emit(error);
  }

  onData(listener: (chunk: Uint8Array) => void): () => void {
    return this.data.add(listener);
  }

  onError(listener: (error: Error) => void): () => void {
    return this.errors.add(listener);
  }

  get listeners(): number {
    return this.data.size;
  }

  setBaudRate(rate: number): Promise<void> {
    this.rates.push(rate);
    this.baudRate = rate;
    return Promise.resolve();
  }

  close(): Promise<void> {
    this.closed = true;
    return Promise.resolve();
  }
}

export const concat = (...parts: Uint8Array[]): Uint8Array => {
  const out = new Uint8Array(parts.reduce((n, p) => n + p.length, 0));
  let at = 0;
  for (const p of parts) {
    out.set(p, at);
    at += p.length;
  }
  return out;
};
