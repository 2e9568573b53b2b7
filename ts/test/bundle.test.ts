import { mkdtempSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import { afterAll, describe, expect, it } from "vitest";
import { bundle } from "../scripts/bundle.mjs";

describe("browser bundle", () => {
  const dir = mkdtempSync(join(tmpdir(), "nurimc-bundle-"));
  afterAll(() => rmSync(dir, { recursive: true, force: true }));

  it("is one self-contained ESM file with the codec, the bus and WebSerialPort, and no Node modules", async () => {
    const file = join(dir, "nurimc.browser.js");
    await bundle(file);
    const text = readFileSync(file, "utf8");
    expect(text).not.toMatch(/from\s+["'](node:|serialport)/);
    expect(text).not.toMatch(/require\(/);
    const lib = (await import(pathToFileURL(file).href)) as typeof import("../src/index.js");
    expect(lib.toHex(lib.encode(lib.make("position_speed", 0, { direction: 0, position: 18000, speed: 1000 })))).toBe(
      "fffe0007760100465003e8",
    );
    expect(typeof lib.WebSerialPort.open).toBe("function");
    expect(typeof lib.Bus).toBe("function");
  });
});
