/**
 * A BytePort over the browser's Web Serial API (Chrome, Edge).
 *
 *   const serial = await navigator.serial.requestPort();   // needs a user gesture
 *   const port = await WebSerialPort.open(serial, 115200);
 *
 * Web Serial cannot change the rate of an open port, so setBaudRate closes and
 * reopens it (written bytes are flushed first).
 */
import { BusError, PortError } from "../bus/errors.js";
import { type BytePort, type DataListener, type ErrorListener, Listeners } from "../bus/port.js";

/** The part of the Web Serial `SerialPort` this class uses (so tests can pass a fake). */
export type WebSerialDevice = Pick<SerialPort, "open" | "close" | "readable" | "writable">;

export class WebSerialPort implements BytePort {
  private readonly data = new Listeners<Uint8Array>();
  private readonly errors = new Listeners<Error>();
  private reader: ReadableStreamDefaultReader<Uint8Array> | null = null;
  private reading: Promise<void> = Promise.resolve();
  private rate: number;
  private isOpen = false;

  private constructor(
    readonly device: WebSerialDevice,
    baudRate: number,
  ) {
    this.rate = baudRate;
  }

  /** Open `device` at `baudRate`, 8N1, no flow control, and start reading. */
  static async open(device: WebSerialDevice, baudRate: number): Promise<WebSerialPort> {
    const port = new WebSerialPort(device, baudRate);
    await port.start();
    return port;
  }

  get baudRate(): number {
    return this.rate;
  }

  async write(data: Uint8Array): Promise<void> {
    const writable = this.device.writable;
    if (!this.isOpen || writable === null) throw new PortError("the serial port is closed; open it again");
    const writer = writable.getWriter();
    try {
      await writer.write(data);
    } catch (err) {
      throw new PortError(`writing to the serial port failed (unplugged?): ${String(err)}`, { cause: err });
    } finally {
      writer.releaseLock();
    }
  }

  onData(listener: DataListener): () => void {
    return this.data.add(listener);
  }

  onError(listener: ErrorListener): () => void {
    return this.errors.add(listener);
  }

  async setBaudRate(rate: number): Promise<void> {
    if (rate === this.rate) return;
    await this.stop();
    this.rate = rate;
    await this.start();
  }

  async close(): Promise<void> {
    await this.stop();
  }

  private async start(): Promise<void> {
    try {
      await this.device.open({ baudRate: this.rate, dataBits: 8, stopBits: 1, parity: "none", flowControl: "none" });
    } catch (err) {
      throw new PortError(
        `cannot open the serial port at ${this.rate} bps (in use by another program or tab?): ${String(err)}`,
        { cause: err },
      );
    }
    this.isOpen = true;
    this.reading = this.readLoop();
  }

  private async stop(): Promise<void> {
    if (!this.isOpen) return;
    this.isOpen = false;
    await this.reader?.cancel().catch(() => undefined);
    await this.reading;
    await this.device.close();
  }

  private async readLoop(): Promise<void> {
    // Web Serial ends a reader on recoverable errors (framing, parity, buffer overrun): take a new one.
    while (this.isOpen && this.device.readable !== null) {
      const reader = this.device.readable.getReader();
      this.reader = reader;
      try {
        for (;;) {
          const { value, done } = await reader.read();
          if (done) return; // the stream ended (the port closed): a new reader would end at once, forever
          if (value.length > 0) this.data.emit(value);
        }
      } catch (err) {
        if (this.isOpen && !isRecoverable(err)) {
          this.isOpen = false;
          this.errors.emit(new BusError(`the serial port failed (unplugged?): ${String(err)}`, { cause: err }));
        }
      } finally {
        reader.releaseLock();
        this.reader = null;
      }
    }
  }
}

function isRecoverable(err: unknown): boolean {
  const name = err instanceof Error ? err.name : "";
  return name === "BreakError" || name === "FramingError" || name === "ParityError" || name === "BufferOverrunError";
}
