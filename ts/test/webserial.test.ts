import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { PortError } from "../src/bus/errors.js";
import { decode, encode, make } from "../src/codec.js";
import { type WebSerialDevice, WebSerialPort } from "../src/ports/webserial.js";

/** A Web Serial SerialPort made of web streams (Node 20 has them): what the browser hands us. */
class FakeSerialDevice implements WebSerialDevice {
  readable: ReadableStream<Uint8Array> | null = null;
  writable: WritableStream<Uint8Array> | null = null;
  readonly opens: SerialOptions[] = [];
  readonly written: Uint8Array[] = [];
  private push: ((chunk: Uint8Array) => void) | null = null;
  private failRead: ((error: Error) => void) | null = null;

  constructor(private readonly answer: (written: Uint8Array) => Uint8Array | null) {}

  open(options: SerialOptions): Promise<void> {
    if (this.readable !== null)
      return Promise.reject(new DOMException("The port is already open.", "InvalidStateError"));
    this.opens.push(options);
    this.readable = new ReadableStream<Uint8Array>({
      start: (controller) => {
        this.push = (chunk) => controller.enqueue(chunk);
        this.failRead = (error) => controller.error(error);
      },
    });
    this.writable = new WritableStream<Uint8Array>({
      write: (chunk) => {
        this.written.push(chunk.slice());
        const reply = this.answer(chunk);
        if (reply !== null) setTimeout(() => this.push?.(reply), 0);
      },
    });
    return Promise.resolve();
  }

  close(): Promise<void> {
    this.readable = null;
    this.writable = null;
    return Promise.resolve();
  }

  /** A USB adapter pulled out: the stream errors with a non-recoverable error. */
  unplug(): void {
    this.failRead?.(new DOMException("The device has been lost.", "NetworkError"));
  }
}

const pingAnswer = (written: Uint8Array): Uint8Array | null => {
  const request = decode(written);
  return request.name === "request_ping" ? encode(make("ping", request.id, {})) : null;
};

describe("WebSerialPort", () => {
  it("opens 8N1 at the rate asked, and carries a request and its answer", async () => {
    const device = new FakeSerialDevice(pingAnswer);
    const bus = new Bus(await WebSerialPort.open(device, 115200), { timing: { latencyMs: 25 } });
    expect(await bus.request(make("request_ping", 3, {}))).toEqual(make("ping", 3, {}));
    expect(device.opens).toEqual([{ baudRate: 115200, dataBits: 8, stopBits: 1, parity: "none", flowControl: "none" }]);
    await bus.close();
    expect(device.readable).toBeNull();
  });

  it("changes the rate by closing and reopening the port, and keeps working", async () => {
    const device = new FakeSerialDevice(pingAnswer);
    const port = await WebSerialPort.open(device, 9600);
    const bus = new Bus(port, { timing: { latencyMs: 25 } });
    await bus.setBaudRate(1_000_000);
    expect(port.baudRate).toBe(1_000_000);
    expect(device.opens.map((o) => o.baudRate)).toEqual([9600, 1_000_000]);
    expect(await bus.request(make("request_ping", 1, {}))).toEqual(make("ping", 1, {}));
    await bus.close();
  });

  it("reports an unplugged device and refuses to write to a closed port", async () => {
    const device = new FakeSerialDevice(pingAnswer);
    const port = await WebSerialPort.open(device, 9600);
    const errors: Error[] = [];
    port.onError((e) => errors.push(e));
    device.unplug();
    await new Promise((r) => setTimeout(r, 10));
    expect(errors.map((e) => e.message)).toEqual([expect.stringMatching(/unplugged\?.*device has been lost/)]);
    await expect(port.write(new Uint8Array([1]))).rejects.toBeInstanceOf(PortError);
  });
});

describe("WebSerialPort on a stream that ends", () => {
  it("stops reading when the readable ends, instead of taking new readers forever", async () => {
    let readers = 0;
    const ended = new ReadableStream<Uint8Array>({ start: (controller) => controller.close() });
    const getReader = ended.getReader.bind(ended);
    const device = {
      readable: Object.assign(ended, {
        getReader: () => {
          readers += 1;
          return getReader();
        },
      }),
      writable: new WritableStream<Uint8Array>(),
      open: () => Promise.resolve(),
      close: () => Promise.resolve(),
    } as unknown as WebSerialDevice;
    const port = await WebSerialPort.open(device, 9600);
    await new Promise((resolve) => setTimeout(resolve, 50)); // a spinning loop would have taken thousands
    expect(readers).toBe(1);
    await port.close();
  });
});
