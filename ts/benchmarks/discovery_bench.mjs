// Discovery across rates, the TypeScript library next to the Python library, in one run on the
// same simulator's pseudo-terminal: the same search should take about the same time (both follow
// the wire: a broadcast per rate, a walk only where answers garble). Usage: node
// benchmarks/discovery_bench.mjs (after tsc). Writes benchmarks/results/discovery-ts.json.
// Not a test: figures vary with the machine (and with how busy it is).
import { execFileSync, spawn } from "node:child_process";
import { writeFileSync } from "node:fs";
import { cpus, loadavg, tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { Bus, discover } from "../dist/index.js";
import { NodeSerialPort } from "../dist/node.js";

const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const PYTHON = join(ROOT, ".venv/bin/python");
const RUNS = 3;
const CASES = [
  {
    name: "3 controllers, 2 lines, 3 rates; all 18 rates searched",
    sim: ["--motor", "3@57600:mc", "--motor", "7@38400:rsa", "--motor", "12@250000:mc"],
    rates: null,
  },
  {
    name: "3 controllers answering together at 115200 (a walk of 255 IDs)",
    sim: ["--ids", "1,2,5", "--baud", "115200"],
    rates: [115200],
  },
];

const PY = `
import json, sys, time
from nurimc import Bus
from nurimc.procedures.discovery import discover
rates = json.loads(sys.argv[2])
with Bus.open(sys.argv[1], baudrate=9600) as bus:
    t = time.perf_counter()
    found = bus.run(discover(bus.core, rates))
    print(json.dumps({"seconds": time.perf_counter() - t, "found": [[f.id, f.baudrate, f.line] for f in found]}))
`;

function startSim(link, args) {
  const sim = spawn(PYTHON, ["-m", "nurimc.sim", "--link", link, ...args], { stdio: ["ignore", "pipe", "inherit"] });
  return new Promise((resolve, reject) => {
    let out = "";
    sim.stdout.on("data", (c) => {
      out += c;
      if (/^ready: /m.test(out)) resolve(sim);
    });
    sim.on("exit", () => reject(new Error("simulator exited")));
  });
}

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const results = [];
for (const c of CASES) {
  const link = join(tmpdir(), `nurimc-disc-bench-${process.pid}-${results.length}`);
  const sim = await startSim(link, c.sim.includes("--ids") ? c.sim : [...c.sim, "--ids", ""]);
  const ts = [];
  const py = [];
  let foundTs = null;
  let foundPy = null;
  for (let run = 0; run < RUNS; run++) {
    const bus = new Bus(await NodeSerialPort.open(link, 9600));
    const t = performance.now();
    const found = await discover(bus, c.rates ? { rates: c.rates } : {});
    ts.push((performance.now() - t) / 1000);
    foundTs = found.map((f) => [f.id, f.baudrate, f.line]);
    await bus.close();
    const answer = JSON.parse(execFileSync(PYTHON, ["-c", PY, link, JSON.stringify(c.rates)], { encoding: "utf8" }));
    py.push(answer.seconds);
    foundPy = answer.found;
  }
  sim.kill("SIGTERM");
  results.push({
    case: c.name,
    typescript_s: ts.map((x) => Number(x.toFixed(3))),
    python_s: py.map((x) => Number(x.toFixed(3))),
    median_ratio_ts_to_python: Number((median(ts) / median(py)).toFixed(2)),
    same_finds: JSON.stringify(foundTs) === JSON.stringify(foundPy),
    found: foundTs,
  });
  console.log(results.at(-1));
}
const out = {
  benchmark:
    "discovery across rates: TypeScript (ts/src/discovery.ts) and Python (nurimc.procedures.discovery) on one simulator pty",
  host: {
    cpus: cpus().length,
    loadavg_1min: Number(loadavg()[0].toFixed(2)),
    note: "a shared, busy 2-core host (several agents working): absolute times are high; the ratio is the figure",
  },
  date: new Date().toISOString(),
  results,
};
writeFileSync(join(ROOT, "ts/benchmarks/results/discovery-ts.json"), `${JSON.stringify(out, null, 2)}\n`);
