// Transaction latency of the TypeScript bus client against the simulator's pseudo-terminal,
// next to a bare `serialport` write-and-read of the same bytes on the same terminal, in one run:
// the library's overhead as a ratio. Usage: node benchmarks/bus_sim_bench.mjs (after tsc).
// Writes benchmarks/results/bus-sim-ts.json. Not a test: figures vary with the machine.
import { spawn } from "node:child_process";
import { writeFileSync } from "node:fs";
import { cpus, tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { SerialPort } from "serialport";
import { Bus, encode, make } from "../dist/index.js";
import { NodeSerialPort } from "../dist/node.js";

const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const LINK = join(tmpdir(), `nurimc-ts-bench-${process.pid}`);
const RATE = 1_000_000;
const N = 400;

const sim = spawn(
  join(ROOT, ".venv/bin/python"),
  ["-m", "nurimc.sim", "--link", LINK, "--ids", "0,", "--baud", String(RATE)],
  { stdio: ["ignore", "pipe", "inherit"] },
);
await new Promise((resolve, reject) => {
  let out = "";
  sim.stdout.on("data", (c) => {
    out += c;
    if (/^ready: /m.test(out)) resolve();
  });
  sim.on("exit", () => reject(new Error("simulator exited")));
});

const request = make("request_position", 0, {});
const frame = encode(request);
const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const ms = (t0) => Number(process.hrtime.bigint() - t0) / 1e6;

async function bare() {
  const port = new SerialPort({ path: LINK, baudRate: RATE });
  await new Promise((r) => port.on("open", r));
  const times = [];
  for (let i = 0; i < N; i++) {
    const t0 = process.hrtime.bigint();
    let got = 0;
    await new Promise((resolve) => {
      const onData = (c) => {
        got += c.length;
        if (got < 12) return;
        port.off("data", onData);
        resolve();
      };
      port.on("data", onData);
      port.write(Buffer.from(frame));
    });
    times.push(ms(t0));
  }
  await new Promise((r) => port.close(r));
  return times;
}

async function library() {
  const bus = new Bus(await NodeSerialPort.open(LINK, RATE), {});
  const times = [];
  for (let i = 0; i < N; i++) {
    const t0 = process.hrtime.bigint();
    await bus.request(request);
    times.push(ms(t0));
  }
  await bus.close();
  return { times, retries: bus.stats.retries };
}

const bareTimes = [...(await bare()), ...(await bare())].slice(N); // second pass: warm
const lib = await library();
sim.kill("SIGTERM");
const results = {
  transactions: N,
  bare_median_ms: Math.round(median(bareTimes) * 1000) / 1000,
  library_median_ms: Math.round(median(lib.times) * 1000) / 1000,
  overhead_ratio: Math.round((median(lib.times) / median(bareTimes)) * 100) / 100,
  library_retries: lib.retries,
};
console.table(results);
const out = {
  results,
  baud: RATE,
  node: process.version,
  cpu: cpus()[0]?.model ?? "",
  date: new Date().toISOString().slice(0, 10),
};
writeFileSync(fileURLToPath(new URL("results/bus-sim-ts.json", import.meta.url)), JSON.stringify(out, null, 2) + "\n");
