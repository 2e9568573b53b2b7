/**
 * The library against the simulator (python -m nurimc.sim) through a Node serial port on
 * its pseudo-terminal: the same path a USB-RS485 adapter takes.
 */
import { type ChildProcess, spawn } from "node:child_process";
import { existsSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { NoAnswerError } from "../src/bus/errors.js";
import { make } from "../src/codec.js";
import { Motor } from "../src/motor.js";
import { NodeSerialPort } from "../src/ports/node.js";

const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const PYTHON = join(ROOT, ".venv", "bin", "python");
const SIM = join(ROOT, "python", "src", "nurimc", "sim", "__main__.py");
const LINK = join(tmpdir(), `nurimc-ts-sim-${process.pid}`);
const RATE = 115200;

/** Start the simulator; resolves with the process once it prints `ready:`. */
function startSim(): Promise<ChildProcess> {
  return new Promise((resolve, reject) => {
    const sim = spawn(PYTHON, ["-m", "nurimc.sim", "--link", LINK, "--ids", "0,1", "--baud", String(RATE)], {
      stdio: ["ignore", "pipe", "pipe"],
    });
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

const present = existsSync(SIM) && existsSync(PYTHON);

// `make test` sets NURIMC_REQUIRE_SIM=1: there a missing simulator is a failure, not a skip.
it.runIf(process.env["NURIMC_REQUIRE_SIM"] === "1")("finds the simulator and the project's Python", () => {
  expect({ simulator: existsSync(SIM), python: existsSync(PYTHON) }).toEqual({ simulator: true, python: true });
});

describe.skipIf(!present)("against the simulator's pseudo-terminal", () => {
  let sim: ChildProcess;
  let bus: Bus;

  beforeAll(async () => {
    sim = await startSim();
    // the library's default timing; a Python simulator on a loaded 2-core machine may now and
    // then miss a deadline, which the default retries absorb
    bus = new Bus(await NodeSerialPort.open(LINK, RATE));
  });

  afterAll(async () => {
    await bus?.close();
    sim?.kill("SIGTERM");
  });

  it("pings the controllers that are there, and not one that is not", async () => {
    expect(await new Motor(bus, 0).ping()).toBe(true);
    expect(await new Motor(bus, 1).ping()).toBe(true);
    await expect(bus.request(make("request_ping", 9, {}), { retries: 0 })).rejects.toBeInstanceOf(NoAnswerError);
  });

  it("writes settings and verifies them by reading back", async () => {
    const motor = new Motor(bus, 1);
    expect(await motor.set("rated-speed", 2000)).toBe(2000);
    expect(await motor.set("ratio", 12.5)).toBe(12.5);
    expect(await motor.set("response-time", 300)).toBe(300);
    expect(await motor.set("position-mode", "relative")).toBe("relative");
    await motor.set("position-mode", "absolute");
    expect(await motor.get("rated-speed")).toBe(2000);
    expect(await motor.get("ratio")).toBe(12.5);
    expect(await motor.get("response-time")).toBe(300);
    await motor.set("position-kp", 60);
    await motor.set("position-rated-current", 4.5);
    const settings = await motor.readSettings();
    expect(settings).toMatchObject({ "position-kp": 60, "position-rated-current": 4.5, "position-mode": "absolute" });
  });

  it("moves a motor: the feedback follows the command and settles at the target", async () => {
    const motor = new Motor(bus, 0);
    const start = await motor.readState();
    // the simulator reports whole encoder steps (22.5 deg at the default resolution 4, ratio 1:1)
    const target = start.position > 90 ? 45 : 180;
    await motor.moveTo(target, { rpm: 300 });
    const seen: number[] = [];
    const deadline = Date.now() + 15_000;
    let state = start;
    while (Date.now() < deadline) {
      state = await motor.readState();
      seen.push(state.position);
      if (Math.abs(state.position - target) < 1 && state.speed === 0) break;
      await new Promise((r) => setTimeout(r, 50));
    }
    expect(Math.abs(state.position - target)).toBeLessThan(1);
    expect(seen.some((p) => Math.abs(p - start.position) > 1 && Math.abs(p - target) > 1)).toBe(true); // it travelled
    await motor.release();
    await new Promise((r) => setTimeout(r, 100));
    expect(await motor.get("control")).toBe("off");
  });

  it("follows a controller to a new baud rate", async () => {
    const motor = new Motor(bus, 1);
    await bus.send(make("set_baud", 1, { baud_index: 11 })); // 57600
    await new Promise((r) => setTimeout(r, 150)); // EEPROM write
    await expect(bus.request(make("request_ping", 1, {}), { retries: 1 })).rejects.toBeInstanceOf(NoAnswerError);
    await bus.setBaudRate(57600);
    expect(await motor.ping()).toBe(true);
    expect(await new Motor(bus, 0).ping()).toBe(false); // ID 0 stayed at 115200
    await bus.setBaudRate(RATE);
  });
});
