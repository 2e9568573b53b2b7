/**
 * Discovery across rates with product lines, against the simulator on a pseudo-terminal:
 * three controllers of two lines at three rates (as the console's direct mode must find them).
 */
import { type ChildProcess, spawn } from "node:child_process";
import { existsSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { DEFAULT_TIMING } from "../src/bus/timing.js";
import { type DiscoveryProgress, discover, walkWaitMs } from "../src/discovery.js";
import { HOST_TIMING } from "../src/generated/host.js";
import { readLineSettings, setLineSetting } from "../src/linesettings.js";
import { NodeSerialPort } from "../src/ports/node.js";

const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const PYTHON = join(ROOT, ".venv", "bin", "python");
const LINK = join(tmpdir(), `nurimc-ts-disc-${process.pid}`);
const MOTORS = ["3@57600:mc", "7@38400:rsa", "12@250000:mc"];
// The simulator is a Python process on a shared, busy 2-core host (vitest runs files in parallel):
// its answers can come later than a pty's 2 ms allows; the deadlines of an unknown USB adapter
// (as the console's direct mode uses) leave room for that.
const BUSY_HOST = { timing: { latencyMs: HOST_TIMING.usbAdapterLatencyMs } };

function startSim(args: string[]): Promise<ChildProcess> {
  return new Promise((resolve, reject) => {
    const sim = spawn(PYTHON, ["-m", "nurimc.sim", "--link", LINK, ...args], { stdio: ["ignore", "pipe", "pipe"] });
    let output = "";
    const timer = setTimeout(() => reject(new Error(`simulator not ready after 20 s:\n${output}`)), 20_000);
    sim.stdout.on("data", (chunk: Buffer) => {
      output += chunk.toString();
      if (/^ready: /m.test(output)) {
        clearTimeout(timer);
        resolve(sim);
      }
    });
    sim.stderr.on("data", (chunk: Buffer) => {
      output += chunk.toString();
    });
    sim.on("exit", (code) => reject(new Error(`simulator exited (${code}) before ready:\n${output}`)));
  });
}

describe("walk wait", () => {
  it("is shorter with a measured broadcast than the assumed response time, and never negative", () => {
    const assumed = walkWaitMs(115200, DEFAULT_TIMING, null);
    const measured = walkWaitMs(115200, DEFAULT_TIMING, 1);
    expect(measured).toBeLessThan(assumed);
    expect(measured).toBeGreaterThan(0);
  });
});

describe.skipIf(!existsSync(PYTHON))("discovery against the simulator", () => {
  let sim: ChildProcess;
  let bus: Bus;
  beforeAll(async () => {
    sim = await startSim(MOTORS.flatMap((m) => ["--motor", m]).concat(["--ids", "", "--baud", "9600"]));
    bus = new Bus(await NodeSerialPort.open(LINK, 9600), BUSY_HOST);
  }, 30_000);
  afterAll(async () => {
    await bus?.close();
    sim?.kill("SIGTERM");
  });

  it("finds three controllers of two lines at three rates, with progress, and leaves the bus at its rate", async () => {
    const seen: DiscoveryProgress[] = [];
    const found = await discover(bus, { onProgress: (p) => seen.push(p) });
    // in the search order of spec/host.json: 57600, then 38400, then 250000
    expect(found.map((f) => [f.id, f.baudrate, f.line, f.collision])).toEqual([
      [3, 57600, "mc", false],
      [7, 38400, "rsa", false],
      [12, 250000, "mc", false],
    ]);
    expect(found.every((f) => f.firmware !== null)).toBe(true);
    expect(new Set(seen.map((p) => p.rate)).size).toBe(18); // every rate searched, the progress says which
    expect(seen.at(-1)?.found.length).toBe(3);
    expect(bus.baudRate).toBe(9600);
  }, 120_000);
});

describe.skipIf(!existsSync(PYTHON))("discovery when answers collide", () => {
  let sim: ChildProcess;
  let bus: Bus;
  beforeAll(async () => {
    sim = await startSim(["--ids", "1,2,5", "--baud", "115200"]);
    bus = new Bus(await NodeSerialPort.open(LINK, 9600), BUSY_HOST);
  }, 30_000);
  afterAll(async () => {
    await bus?.close();
    sim?.kill("SIGTERM");
  });

  it("walks the IDs when the broadcast answers garble, and finds each one", async () => {
    const walked: number[] = [];
    const found = await discover(bus, {
      rates: [115200],
      onProgress: (p) => {
        if (p.walkingId !== null && p.phase === "rates") walked.push(p.walkingId);
      },
    });
    expect(found.map((f) => [f.id, f.baudrate, f.line])).toEqual([
      [1, 115200, "mc"],
      [2, 115200, "mc"],
      [5, 115200, "mc"],
    ]);
    expect(walked.length).toBeGreaterThan(200); // the walk happened: every ID was asked
  }, 120_000);
});

describe.skipIf(!existsSync(PYTHON))("settings of another product line", () => {
  let sim: ChildProcess;
  let bus: Bus;
  beforeAll(async () => {
    sim = await startSim(["--motor", "7@38400:rsa", "--motor", "9@38400:sm", "--ids", "", "--baud", "9600"]);
    bus = new Bus(await NodeSerialPort.open(LINK, 38400));
  }, 30_000);
  afterAll(async () => {
    await bus?.close();
    sim?.kill("SIGTERM");
  });

  it("reads an RSA's settings in its own table and writes a gain, read back", async () => {
    const before = await readLineSettings(bus, "rsa", 7);
    expect(Object.keys(before)).toContain("position-kp");
    expect(Object.keys(before)).not.toContain("resolution"); // RSA has none
    const kp = before["position-kp"] === 70 ? 71 : 70;
    expect(await setLineSetting(bus, "rsa", 7, "position-kp", kp)).toBe(kp);
    const after = await readLineSettings(bus, "rsa", 7);
    expect(after["position-kp"]).toBe(kp);
    expect(after["position-ki"]).toBe(before["position-ki"]); // the shared command kept the others
  }, 30_000);

  it("refuses a setting the line cannot write, before sending anything", async () => {
    await expect(setLineSetting(bus, "sm", 9, "speed-kp", 5)).rejects.toThrow(/cannot be written .* sm line/);
    await expect(setLineSetting(bus, "rsa", 7, "resolution", 5)).rejects.toThrow(/cannot be written/);
  });
});
