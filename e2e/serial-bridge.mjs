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

// RFC 2217 (Telnet COM-PORT-OPTION) numbers: the client's command; the server answers +100
const IAC = 255;
const SB = 250;
const SE = 240;
const WILL = 251;
const WONT = 252;
const DO = 253;
const DONT = 254;
const COM_PORT_OPTION = 44;
const SET_BAUDRATE = 1;

/** Reads the server's bytes: data (IAC IAC is one 0xFF) to `onData`, RFC 2217 answers to `onSub`. */
export function telnetReader(onData, onSub, reply) {
  let state = "data";
  let sub = [];
  return (chunk) => {
    const data = [];
    for (const byte of chunk) {
      if (state === "data") {
        if (byte === IAC) state = "iac";
        else data.push(byte);
      } else if (state === "iac") {
        if (byte === IAC) {
          data.push(IAC);
          state = "data";
        } else if (byte === SB) {
          sub = [];
          state = "sub";
        } else if (byte >= WILL && byte <= DONT) state = byte;
        else state = "data";
      } else if (typeof state === "number") {
        // the server asks to enable an option we did not ask for: refuse (COM-PORT-OPTION is ours)
        if (byte !== COM_PORT_OPTION && (state === WILL || state === DO))
          reply([IAC, state === WILL ? DONT : WONT, byte]);
        state = "data";
      } else if (state === "sub") {
        if (byte === IAC) state = "sub-iac";
        else sub.push(byte);
      } else {
        if (byte === IAC) {
          sub.push(IAC);
          state = "sub";
        } else {
          if (byte === SE) onSub(sub);
          state = "data";
        }
      }
    }
    if (data.length) onData(data);
  };
}

/** Node's end of the bridge over RFC 2217: one TCP connection to `nurimc sim --tcp`, the rate the
 * page opens its port at sent as SET-BAUDRATE (answered before the port counts as open), 0xFF
 * doubled in the data both ways. Several rates over one TCP port, as the pty gives. */
export async function startRfc2217Bridge(p, host, port) {
  const net = await import("node:net");
  const state = { socket: null, waiting: null };
  const rates = []; // every rate the server confirmed, in order
  const send = (bytes) =>
    new Promise((resolve, reject) => state.socket.write(Uint8Array.from(bytes), (e) => (e ? reject(e) : resolve())));
  const read = telnetReader(
    (data) => p.evaluate((bytes) => window.__serialData(bytes), data).catch(() => {}),
    (sub) => {
      if (sub[0] !== COM_PORT_OPTION || sub[1] !== SET_BAUDRATE + 100 || sub.length < 6) return;
      const rate = ((sub[2] << 24) >>> 0) + (sub[3] << 16) + (sub[4] << 8) + sub[5];
      state.waiting?.(rate);
    },
    (bytes) => send(bytes).catch(() => {}),
  );
  const setRate = (rate) =>
    new Promise((resolve, reject) => {
      const timer = setTimeout(() => reject(new Error(`RFC 2217: no answer to SET-BAUDRATE ${rate} in 10 s`)), 10000);
      state.waiting = (got) => {
        clearTimeout(timer);
        state.waiting = null;
        if (got === rate) {
          rates.push(rate);
          resolve();
        } else reject(new Error(`RFC 2217: asked ${rate} bps, the server is at ${got}`));
      };
      const value = [rate >>> 24, (rate >>> 16) & 255, (rate >>> 8) & 255, rate & 255].flatMap((b) =>
        b === IAC ? [IAC, IAC] : [b],
      );
      send([IAC, SB, COM_PORT_OPTION, SET_BAUDRATE, ...value, IAC, SE]).catch(reject);
    });
  await p.exposeFunction("__serialOpen", async (rate) => {
    if (state.socket === null) {
      state.socket = await new Promise((resolve, reject) => {
        const socket = net.connect({ host, port }, () => resolve(socket));
        socket.once("error", reject);
      });
      state.socket.setNoDelay(true);
      state.socket.on("data", read);
      await send([IAC, WILL, COM_PORT_OPTION]); // Telnet first: the server takes us for RFC 2217
    }
    await setRate(rate);
  });
  await p.exposeFunction("__serialWrite", (bytes) =>
    state.socket ? send(bytes.flatMap((b) => (b === IAC ? [IAC, IAC] : [b]))) : undefined,
  );
  await p.addInitScript(SERIAL_BRIDGE);
  return { rates, close: () => state.socket?.destroy() };
}
