/**
 * Backup and restore in the CLI's format against the simulator: a backup made by the library is
 * restored by `nurimc restore`, one made by `nurimc backup` is restored by the library; a file of
 * another product line writes nothing; a restore cut off by a lost port leaves its journal mark,
 * and running it again completes it.
 */
import { type ChildProcess, execFile, spawn } from "node:child_process";
import { existsSync, mkdtempSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { promisify } from "node:util";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { backupText, makeBackup, parseBackup, restoreBackup, StorageJournal } from "../src/backup.js";
import { Bus } from "../src/bus/client.js";
import type { BytePort } from "../src/bus/port.js";
import { discover, type Found } from "../src/discovery.js";
import { readLineSettings, setLineSetting } from "../src/linesettings.js";
import { Motor } from "../src/motor.js";
import { NodeSerialPort } from "../src/ports/node.js";

const run = promisify(execFile);
const ROOT = fileURLToPath(new URL("../..", import.meta.url));
const PYTHON = join(ROOT, ".venv", "bin", "python");
const NURIMC = join(ROOT, ".venv", "bin", "nurimc");
const DIR = mkdtempSync(join(tmpdir(), "nurimc-ts-backup-"));
const LINK = join(DIR, "link");

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

const cli = (...args: string[]) =>
  run(NURIMC, ["--port", LINK, "--baud", "57600", "--id", "3", ...args], {
    env: { ...process.env, NURIMC_STATE_DIR: join(DIR, "state"), NO_COLOR: "1" },
  });

const cliAt = (rate: number, id: number, ...args: string[]) =>
  run(NURIMC, ["--port", LINK, "--baud", String(rate), "--id", String(id), ...args], {
    env: { ...process.env, NURIMC_STATE_DIR: join(DIR, "state"), NO_COLOR: "1" },
  });

function memoryStorage() {
  const store = new Map<string, string>();
  return {
    getItem: (k: string) => store.get(k) ?? null,
    setItem: (k: string, v: string) => void store.set(k, v),
    removeItem: (k: string) => void store.delete(k),
  };
}

describe.skipIf(!existsSync(NURIMC))("backup and restore with the CLI, against the simulator", () => {
  let sim: ChildProcess;
  let bus: Bus;
  let found: Found[];
  const open = async () => {
    bus = new Bus(await NodeSerialPort.open(LINK, 57600));
  };
  beforeAll(async () => {
    sim = await startSim(["--motor", "3@57600:mc", "--motor", "7@38400:rsa", "--ids", "", "--state", join(DIR, "sim")]);
    await open();
    found = await discover(bus, { rates: [57600, 38400] });
  }, 60_000);
  afterAll(async () => {
    await bus?.close();
    sim?.kill("SIGTERM");
  });

  it("finds the two lines", () => {
    expect(found.map((f) => [f.id, f.line])).toEqual([
      [3, "mc"],
      [7, "rsa"],
    ]);
  });

  it("makes a backup that `nurimc restore` accepts and restores", async () => {
    const motor = new Motor(bus, 3);
    const mine = await makeBackup(
      bus,
      found.filter((f) => f.id === 3),
    );
    expect(mine.motors[0]?.settings["position-kp"]).toBe(await motor.get("position-kp"));
    const file = join(DIR, "browser.json");
    writeFileSync(file, backupText(mine));
    const kp = mine.motors[0]?.settings["position-kp"] as number;
    await motor.set("position-kp", kp === 77 ? 78 : 77);
    await bus.close();
    const { stdout } = await cli("restore", file);
    expect(stdout).toContain("position-kp");
    await open();
    expect(await new Motor(bus, 3).get("position-kp")).toBe(kp);
  }, 60_000);

  it("restores a backup made by `nurimc backup`, each row verified", async () => {
    await bus.close();
    const file = join(DIR, "cli.json");
    await cli("backup", file);
    await open();
    const document = parseBackup(readFileSync(file, "utf8"), "cli.json");
    const kp = document.motors[0]?.settings["position-kp"] as number;
    await new Motor(bus, 3).set("position-kp", kp === 66 ? 67 : 66);
    const journal = new StorageJournal(memoryStorage(), "sim");
    const rows = await restoreBackup(bus, document, found, journal, "cli.json");
    expect(rows).toEqual([expect.objectContaining({ id: 3, setting: "position-kp", after: kp, verified: true })]);
    expect(journal.pending(3)).toBeNull();
    expect(await new Motor(bus, 3).get("position-kp")).toBe(kp);
    expect(await restoreBackup(bus, document, found, journal, "cli.json")).toEqual([]); // nothing differs now
  }, 60_000);

  it("refuses a file from another product line and writes nothing", async () => {
    const file = parseBackup(readFileSync(join(DIR, "cli.json"), "utf8"), "cli.json");
    const motor = new Motor(bus, 3);
    const before = await motor.readSettings();
    const other = { ...file, motors: [{ ...file.motors[0], id: 3, product: "rsa", settings: { "position-kp": 9 } }] };
    const journal = new StorageJournal(memoryStorage(), "sim");
    await expect(restoreBackup(bus, parseBackup(JSON.stringify(other)), found, journal, "rsa.json")).rejects.toThrow(
      /another product line; nothing was written/,
    );
    expect(journal.pending(3)).toBeNull();
    expect(await motor.readSettings()).toEqual(before);
  }, 60_000);

  it("a restore cut off by a lost port stays marked, and running it again completes it", async () => {
    const document = parseBackup(readFileSync(join(DIR, "cli.json"), "utf8"), "cli.json");
    const kp = document.motors[0]?.settings["position-kp"] as number;
    await new Motor(bus, 3).set("position-kp", kp === 55 ? 56 : 55);
    const journal = new StorageJournal(memoryStorage(), "sim");
    // the cable pulled as the first setting is written: that write fails, the port reports it gone
    const real = bus.port;
    let writes = 0;
    const errors = new Set<(error: Error) => void>();
    const losing: BytePort = {
      get baudRate() {
        return real.baudRate;
      },
      write: (data) => {
        writes += 1;
        if (writes < 3) return real.write(data); // the two agreeing reads
        const gone = new Error("the port is gone (USB cable pulled)");
        for (const listener of errors) listener(gone);
        return Promise.reject(gone);
      },
      onData: (listener) => real.onData(listener),
      onError: (listener) => {
        errors.add(listener);
        return () => errors.delete(listener);
      },
      setBaudRate: (rate) => real.setBaudRate(rate),
      close: () => real.close(),
    };
    await expect(restoreBackup(new Bus(losing), document, found, journal, "cli.json")).rejects.toThrow(/gone/);
    await bus.close();
    expect(journal.pending(3)).toBe("cli.json");
    await open();
    expect(await new Motor(bus, 3).get("position-kp")).not.toBe(kp); // nothing was written
    await restoreBackup(bus, document, found, journal, "cli.json");
    expect(journal.pending(3)).toBeNull();
    expect(await new Motor(bus, 3).get("position-kp")).toBe(kp);
  }, 60_000);

  it("backs up an RSA in its own table; `nurimc restore` accepts it, and the library restores it", async () => {
    const rsa = found.filter((f) => f.id === 7);
    const mine = await makeBackup(bus, rsa);
    expect(mine.motors[0]?.product).toBe("rsa");
    expect(Object.keys(mine.motors[0]?.settings ?? {})).not.toContain("resolution");
    const kp = mine.motors[0]?.settings["position-kp"] as number;
    const file = join(DIR, "rsa.json");
    writeFileSync(file, backupText(mine));
    await bus.setBaudRate(38400);
    await setLineSetting(bus, "rsa", 7, "position-kp", kp === 44 ? 45 : 44);
    await bus.close();
    const { stdout } = await cliAt(38400, 7, "restore", file);
    expect(stdout).toContain("position-kp");
    await open();
    await bus.setBaudRate(38400);
    expect((await readLineSettings(bus, "rsa", 7))["position-kp"]).toBe(kp);
    await setLineSetting(bus, "rsa", 7, "position-kp", kp === 43 ? 42 : 43);
    const journal = new StorageJournal(memoryStorage(), "sim");
    const rows = await restoreBackup(bus, mine, found, journal, "rsa.json");
    expect(rows).toEqual([expect.objectContaining({ id: 7, setting: "position-kp", after: kp, verified: true })]);
    await bus.setBaudRate(38400);
    expect((await readLineSettings(bus, "rsa", 7))["position-kp"]).toBe(kp);
  }, 60_000);
});
