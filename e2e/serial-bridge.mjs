// A navigator.serial for the page whose port carries real bytes to the simulator's
// pseudo-terminal, opened from Node at the rate the page opens its port at (Web Serial reopens
// the port to change rate; the stand-in gives new streams each time). So direct mode runs end to
// end: Web Serial API -> TS client -> bytes -> simulator, at every rate the simulator models.
import { spawn } from "node:child_process";
import { join } from "node:path";
import { NURIMC_BIN, ROOT } from "./lib.mjs";

// Before any page script: a navigator.serial whose port carries real bytes (through Node).
export const SERIAL_BRIDGE = () => {
  let push = null;
  let streams = null;
  let pulled = false;
  const lost = () => new DOMException("The device has been lost.", "NetworkError");
  // the USB cable pulled: reads fail, writes fail, the port cannot be opened again
  window.__pullCable = () => {
    pulled = true;
    try {
      push?.error(lost());
    } catch {
      /* closed already */
    }
  };
  window.__serialData = (bytes) => {
    try {
      push?.enqueue(new Uint8Array(bytes));
    } catch {
      /* closed between rates */
    }
  };
  const port = {
    get readable() {
      return streams?.readable ?? null;
    },
    get writable() {
      return streams?.writable ?? null;
    },
    getInfo: () => ({ usbVendorId: 0x0403, usbProductId: 0x6001 }),
    open: async (options) => {
      if (pulled) throw lost();
      await window.__serialOpen(options.baudRate);
      window.__serialOpened ??= options; // the rate the user chose (discovery then tries the others)
      streams = {
        readable: new ReadableStream({
          start(controller) {
            push = controller;
          },
        }),
        writable: new WritableStream({
          write: (chunk) => {
            if (pulled) throw lost();
            return window.__serialWrite([...chunk]);
          },
        }),
      };
    },
    close: async () => {
      try {
        push?.close();
      } catch {
        /* already */
      }
      push = null;
      streams = null;
    },
  };
  Object.defineProperty(navigator, "serial", {
    value: { requestPort: async () => port, getPorts: async () => [port] },
  });
};

/** Node's end of the bridge: the simulator's pty at the rate the page opens its port at. */
export async function startBridge(p, link) {
  const { NodeSerialPort } = await import(join(ROOT, "ts/dist/node.js"));
  const state = { port: null };
  await p.exposeFunction("__serialOpen", async (rate) => {
    if (state.port === null) {
      state.port = await NodeSerialPort.open(link, rate);
      state.port.onData((chunk) => p.evaluate((bytes) => window.__serialData(bytes), [...chunk]).catch(() => {}));
    } else await state.port.setBaudRate(rate);
  });
  await p.exposeFunction("__serialWrite", (bytes) => state.port?.write(Uint8Array.from(bytes)));
  await p.addInitScript(SERIAL_BRIDGE);
  return { close: () => state.port?.close() };
}

/** `nurimc sim --link LINK ...` (a pseudo-terminal); resolves once it prints `ready:`. */
export function startPtySimulator(link, args) {
  const child = spawn(NURIMC_BIN, ["sim", "--link", link, ...args], { stdio: ["ignore", "pipe", "pipe"] });
  let output = "";
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`simulator did not start in 30 s:\n${output}`)), 30000);
    const look = (chunk) => {
      output += chunk;
      if (/^ready: /m.test(output)) {
        clearTimeout(timer);
        resolve({ child, stop: () => child.kill("SIGTERM") });
      }
    };
    child.stdout.on("data", look);
    child.stderr.on("data", look);
    child.on("exit", (code) => {
      clearTimeout(timer);
      reject(new Error(`simulator exited with ${code}:\n${output}`));
    });
  });
}
