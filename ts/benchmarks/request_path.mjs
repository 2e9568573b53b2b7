// The TypeScript bus's request path against a bare `serialport` loop (issue 33): position feedback
// from one controller, request (6 bytes) + answer (12 bytes), for SECONDS on LINK at 1 Mbps.
// Usage: node benchmarks/request_path.mjs library|bare LINK SECONDS   (after tsc: it runs dist/)
// After 500 warm-up requests, prints one JSON line: {"cycles", "failed", "wall", "cpu"}, cpu being
// this process's user + system time (process.cpuUsage(): every thread, libuv's pool included).
// Not a test: benchmarks/request_path_bench.py runs it against the simulator, alternating the kinds.
//
// library: `motor.readState()` on a `Bus` over `NodeSerialPort`, the bus's defaults.
// bare:    the least a Node program does with `serialport`: write the 6 bytes, wait for 12 bytes
//          of 'data' (0.1 s without them is a failure).
import { SerialPort } from "serialport";
import { Bus, encode, Motor, make } from "../dist/index.js";
import { NodeSerialPort } from "../dist/node.js";

const RATE = 1_000_000;
const ID = 1;
const WARM_UP = 500; // V8 compiles the hot paths meanwhile (its compiler threads' CPU would count)
const [kind, link, secondsText] = process.argv.slice(2);
const seconds = Number(secondsText);
if (!["library", "bare"].includes(kind) || !link || !(seconds > 0)) {
  console.error("usage: node benchmarks/request_path.mjs library|bare LINK SECONDS");
  process.exit(2);
}

/** Runs `one` for `seconds` after a warm-up; what was done, the wall time and the process's CPU (s). */
async function loop(one) {
  for (let i = 0; i < WARM_UP; i++) await one();
  let cycles = 0;
  let failed = 0;
  const cpu0 = process.cpuUsage();
  const start = performance.now();
  const end = start + seconds * 1000;
  do {
    const ok = await one();
    cycles += 1;
    failed += ok ? 0 : 1;
  } while (performance.now() < end);
  const wall = (performance.now() - start) / 1000;
  const cpu = process.cpuUsage(cpu0);
  return { cycles, failed, wall, cpu: (cpu.user + cpu.system) / 1e6 };
}

async function bare() {
  const port = new SerialPort({ path: link, baudRate: RATE, autoOpen: false });
  await new Promise((resolve, reject) => port.open((err) => (err ? reject(err) : resolve())));
  const frame = Buffer.from(encode(make("request_position", ID, {})));
  let got = 0;
  let done = null;
  port.on("data", (chunk) => {
    got += chunk.length;
    if (got >= 12 && done !== null) done(true);
  });
  const one = () =>
    new Promise((resolve) => {
      got = 0;
      const timer = setTimeout(() => finish(false), 100);
      const finish = (ok) => {
        clearTimeout(timer);
        done = null;
        resolve(ok);
      };
      done = finish;
      port.write(frame);
    });
  const result = await loop(one);
  await new Promise((resolve) => port.close(resolve));
  return result;
}

async function library() {
  const bus = new Bus(await NodeSerialPort.open(link, RATE));
  const motor = new Motor(bus, ID);
  const one = async () => {
    try {
      await motor.readState();
      return true;
    } catch {
      return false;
    }
  };
  const result = await loop(one);
  await bus.close();
  return result;
}

console.log(JSON.stringify(kind === "library" ? await library() : await bare()));
