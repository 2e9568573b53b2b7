/**
 * A BytePort over the npm `serialport` package (Node): USB-RS485 adapters, pseudo-terminals.
 *
 *   const port = await NodeSerialPort.open("/dev/ttyUSB0", 115200);
 */
import type { SerialPort } from "serialport";
import { PortError } from "../bus/errors.js";
import { type BytePort, type DataListener, type ErrorListener, Listeners } from "../bus/port.js";

export class NodeSerialPort implements BytePort {
  private readonly data = new Listeners<Uint8Array>();
  private readonly errors = new Listeners<Error>();
  private closing = false;

  private constructor(readonly serial: SerialPort) {
    serial.on("data", (chunk: Buffer) => this.data.emit(new Uint8Array(chunk.buffer, chunk.byteOffset, chunk.length)));
    serial.on("error", (err: Error) => this.errors.emit(err));
    serial.on("close", () => {
      if (!this.closing) this.errors.emit(new PortError(`${serial.path} closed under us (unplugged?)`));
    });
  }

  /** Open `path` at `baudRate`, 8N1 (any of the 18 rates, including non-standard ones on Linux). */
  static async open(path: string, baudRate: number): Promise<NodeSerialPort> {
    const { SerialPort } = await loadSerialport();
    return new Promise((resolve, reject) => {
      const serial = new SerialPort({ path, baudRate, dataBits: 8, stopBits: 1, parity: "none", autoOpen: false });
      serial.open((err) => (err ? reject(portError(path, err)) : resolve(new NodeSerialPort(serial))));
    });
  }

  get baudRate(): number {
    return this.serial.baudRate;
  }

  write(data: Uint8Array): Promise<void> {
    return new Promise((resolve, reject) => {
      this.serial.write(Buffer.from(data.buffer, data.byteOffset, data.length), (err) =>
        err ? reject(portError(this.serial.path, err)) : resolve(),
      );
    });
  }

  onData(listener: DataListener): () => void {
    return this.data.add(listener);
  }

  onError(listener: ErrorListener): () => void {
    return this.errors.add(listener);
  }

  setBaudRate(rate: number): Promise<void> {
    return new Promise((resolve, reject) => {
      this.serial.drain((drainError) => {
        if (drainError) return reject(portError(this.serial.path, drainError));
        this.serial.update({ baudRate: rate }, (err) => (err ? reject(portError(this.serial.path, err)) : resolve()));
      });
    });
  }

  close(): Promise<void> {
    if (!this.serial.isOpen) return Promise.resolve();
    this.closing = true;
    return new Promise((resolve) => this.serial.close(() => resolve()));
  }
}

/** The npm `serialport` package, loaded when a port is opened: it is an optional peer dependency,
 * so `npm install nurimc` for the codec alone runs no native install scripts. */
async function loadSerialport(): Promise<typeof import("serialport")> {
  try {
    return await import("serialport");
  } catch (err) {
    throw new PortError(
      "opening a serial port from Node needs the npm package serialport (an optional peer dependency): npm install serialport",
      { cause: err },
    );
  }
}

/** The port's error, with the fix for the usual causes. */
function portError(path: string, err: Error): PortError {
  const text = err.message;
  let fix = "";
  if (/ENOENT|No such file/i.test(text))
    fix = "; no such device: check the cable and the name (ls /dev/ttyUSB* /dev/ttyACM*)";
  else if (/EACCES|Permission denied/i.test(text))
    fix = "; permission denied: add yourself to the dialout group (sudo usermod -aG dialout $USER, then log in again)";
  else if (/EBUSY|Resource busy|Cannot lock/i.test(text)) fix = "; the port is in use by another program: close it";
  return new PortError(`${path}: ${text}${fix}`, { cause: err });
}
