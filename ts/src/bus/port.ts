/** The abstract byte port the bus client talks through (Web Serial, Node serial, a test fake...). */

export type DataListener = (chunk: Uint8Array) => void;
export type ErrorListener = (error: Error) => void;

/**
 * A serial line: write bytes, receive bytes by callback (or `receive()` as an async
 * iterator), change the baud rate, close. Implementations deliver every received
 * byte to every listener, in order.
 */
export interface BytePort {
  /** The rate the line is set to now (bits per second). */
  readonly baudRate: number;
  /** Send bytes; resolves once the port has taken them (not necessarily on the wire yet). */
  write(data: Uint8Array): Promise<void>;
  /** Call `listener` with every chunk received from now on; returns the unsubscribe function. */
  onData(listener: DataListener): () => void;
  /** Call `listener` when the port fails (unplugged, closed under us); returns the unsubscribe function. */
  onError(listener: ErrorListener): () => void;
  /** Change the line's rate (every byte already written has been sent by then). */
  setBaudRate(rate: number): Promise<void>;
  close(): Promise<void>;
}

/** The listener bookkeeping every port needs. */
export class Listeners<T> {
  private readonly set = new Set<(value: T) => void>();

  add(listener: (value: T) => void): () => void {
    this.set.add(listener);
    return () => this.set.delete(listener);
  }

  emit(value: T): void {
    for (const listener of [...this.set]) listener(value);
  }

  get size(): number {
    return this.set.size;
  }
}

/** Received bytes as an async iterator (ends when `signal` aborts); buffers while the consumer is busy. */
export async function* receive(port: BytePort, signal?: AbortSignal): AsyncGenerator<Uint8Array> {
  const queue: Uint8Array[] = [];
  let wake: (() => void) | null = null;
  const notify = (): void => {
    wake?.();
    wake = null;
  };
  const unsubscribe = port.onData((chunk) => {
    queue.push(chunk);
    notify();
  });
  signal?.addEventListener("abort", notify);
  try {
    while (signal?.aborted !== true) {
      const chunk = queue.shift();
      if (chunk !== undefined) yield chunk;
      else
        await new Promise<void>((resolve) => {
          wake = resolve;
        });
    }
  } finally {
    unsubscribe();
    signal?.removeEventListener("abort", notify);
  }
}
