// The static site (make site) from outside, as issue #34's "done when" says: only the built site/
// served by `python3 -m http.server` (no nurimc server), headless Chromium, a Web Serial port
// bridged to the simulator holding three controllers of two product lines at three rates the
// page is not told. The page finds all three with their lines; writes a gain (verified; the
// simulator's state file agrees); runs a step response with its figures; makes a backup that
// `nurimc restore` accepts and restores one made by `nurimc backup`; refuses a garbled file and
// a file of another product line; changes an ID and finds the motor there; the E-STOP turns
// every motor off; the manifest and service worker make it installable, a reload with the
// server stopped still opens the page, and a new version is picked up on the next load and
// says so. A browser without navigator.serial sees the explanation.
//
// The bridge: the page's navigator.serial is a stand-in whose bytes go to the simulator's
// pseudo-terminal, opened from Node at the rate the page asks (a raw TCP link carries no rate).
// With NURIMC_SITE_BRIDGE=rfc2217 they go to the simulator's TCP port instead, over RFC 2217:
// the rate the page opens its port at is sent as SET-BAUDRATE (the issue's own setup). The CLI
// checks go through the simulator's TCP server, raw (at 57600, the rate of ID 3).

import assert from "node:assert/strict";
import { execFile, spawn } from "node:child_process";
import { cpSync, existsSync, mkdtempSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { after, before, test } from "node:test";
import { promisify } from "node:util";
import { launchBrowser, NURIMC_BIN, ROOT } from "./lib.mjs";
import { startBridge, startRfc2217Bridge } from "./serial-bridge.mjs";

const run = promisify(execFile);
const SITE = join(ROOT, "site");
const DIR = mkdtempSync(join(tmpdir(), "nurimc-site-"));
const LINK = join(DIR, "bus");
const STATE = join(DIR, "state");
const MOTORS = ["3@57600:mc", "7@38400:rsa", "12@250000:mc"];
const BRIDGE = process.env.NURIMC_SITE_BRIDGE ?? "pty"; // pty or rfc2217
let browser, server, sim, tcpPort, page, url, bridge;
const problems = [];

function waitFor(child, pattern, what, ms = 30000) {
  let output = "";
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`${what} not ready in ${ms / 1000} s:\n${output}`)), ms);
    const look = (chunk) => {
      output += chunk;
      const match = pattern.exec(output);
      if (match) {
        clearTimeout(timer);
        resolve(match);
      }
    };
    child.stdout.on("data", look);
    child.stderr.on("data", look);
    child.on("exit", (code) => reject(new Error(`${what} exited with ${code}:\n${output}`)));
  });
}

/** python3 -m http.server on site/ (port 0: a free one, or the one given to come back on). */
async function serve(dir, port = 0) {
  const child = spawn("python3", ["-u", "-m", "http.server", String(port), "--bind", "127.0.0.1", "--directory", dir], {
    stdio: ["ignore", "pipe", "pipe"],
  });
  const match = await waitFor(child, /port (\d+)/, "python3 -m http.server");
  return { child, port: Number(match[1]), stop: () => child.kill("SIGTERM") };
}

/** The CLI against the simulator's TCP server (clients talk at 57600 there: ID 3's rate). */
const cli = (...args) =>
  run(NURIMC_BIN, ["--port", `socket://127.0.0.1:${tcpPort}`, "--baud", "57600", "--id", "3", ...args], {
    env: { ...process.env, NURIMC_STATE_DIR: join(DIR, "cli-state"), NO_COLOR: "1" },
  });

const simState = () => JSON.parse(readFileSync(join(STATE, "bus.json"), "utf8"));

function watch(p) {
  p.on("console", (m) => {
    if (m.type() === "error") problems.push(`console: ${m.text()}`);
  });
  p.on("pageerror", (error) => problems.push(`page error: ${error.message}`));
}

const view = (name) => page.click(`nav button[data-view="${name}"]`);
/** Wait, and on a timeout say what the page showed. */
async function until(fn, arg, ms = 30000) {
  try {
    await page.waitForFunction(fn, arg, { timeout: ms });
  } catch (error) {
    const shown = await page.evaluate(async () => ({
      direct: await window.dashboard.link.request("read_settings", { id: 3 }).then(
        (r) => JSON.stringify(r).slice(0, 200),
        (e) => `error ${e.message}`,
      ),
      rows: document.querySelectorAll("#settings-table tbody tr").length,
      kpRow: document.querySelector("#setting-position-kp")?.outerHTML.slice(0, 300),
      messages: document.querySelector("#messages")?.textContent,
      status: document.querySelector("#status")?.textContent,
    }));
    throw new Error(`${error.message}\npage: ${JSON.stringify(shown)}\nproblems: ${problems.join(" | ")}`);
  }
}
const messages = () => page.textContent("#messages");

before(async () => {
  assert.ok(existsSync(join(SITE, "index.html")), "site/ is built by `make site`");
  const simulator = spawn(
    NURIMC_BIN,
    [
      "sim",
      "--link",
      LINK,
      ...MOTORS.flatMap((m) => ["--motor", m]),
      "--ids",
      "",
      "--baud",
      "57600",
      "--tcp",
      "0",
      "--state",
      STATE,
    ],
    { stdio: ["ignore", "pipe", "pipe"] },
  );
  sim = { stop: () => simulator.kill("SIGTERM") };
  [tcpPort] = (await waitFor(simulator, /tcp 127\.0\.0\.1:(\d+)/, "nurimc sim")).slice(1).map(Number);
  server = await serve(SITE);
  url = `http://127.0.0.1:${server.port}/`;
  browser = await launchBrowser();
  page = await browser.newPage();
  page.setDefaultTimeout(30000);
  watch(page);
  bridge = BRIDGE === "rfc2217" ? await startRfc2217Bridge(page, "127.0.0.1", tcpPort) : await startBridge(page, LINK);
});

after(async () => {
  await browser?.close();
  await bridge?.close();
  server?.stop();
  sim?.stop();
});

test("the site alone finds three controllers of two lines at three rates, with progress", async () => {
  await page.goto(url);
  await page.waitForFunction(() => window.dashboard?.mode === "direct" && !document.querySelector("#connect").disabled);
  assert.equal(
    await page.getAttribute("html", "data-site-version"),
    readFileSync(join(SITE, "version.js"), "utf8").match(/"(\w+)"/)[1],
  );
  await page.click("#connect"); // at the default 9600: none of the three is there
  await page.waitForFunction(() => document.querySelector("#discover-text").dataset.found, null, { timeout: 90000 });
  assert.equal(await page.getAttribute("#discover-text", "data-found"), "3,7,12");
  assert.ok((await page.evaluate(() => window.dashboard.progressEvents)) >= 18, "progress for every rate");
  if (BRIDGE === "rfc2217") {
    // the rates went to the simulator's TCP port as SET-BAUDRATE, each confirmed
    for (const rate of [57600, 38400, 250000]) assert.ok(bridge.rates.includes(rate), `SET-BAUDRATE ${rate}`);
  }
  const subtitles = await page.$$eval(".card", (cards) => cards.map((c) => c.textContent));
  assert.match(
    subtitles.find((s) => s.includes("57600")),
    /MC or BLMC-H/,
  );
  assert.match(
    subtitles.find((s) => s.includes("38400")),
    /RSA or SA/,
  );
  assert.match(
    subtitles.find((s) => s.includes("250000")),
    /MC or BLMC-H/,
  );
});

test("a gain written in the settings view is shown verified, and the simulator's state agrees", async () => {
  await view("settings");
  await page.selectOption("#settings-motor", "3");
  await until(() => document.querySelector("#setting-position-kp .value")?.textContent.trim());
  await page.fill("#setting-position-kp input", "77");
  await page.click("#setting-position-kp .write button");
  await page.waitForFunction(() => document.querySelector("#setting-position-kp .result").className.includes("ok"));
  assert.match(await page.textContent("#setting-position-kp .result"), /77/);
  const slots = JSON.stringify(simState());
  assert.match(
    slots,
    /"kp":\s*77|"position_kp":\s*77/,
    `the simulator's state file holds kp 77: ${slots.slice(0, 400)}`,
  );
});

test("a gain of the RSA (another product line) is written in its own table and shown verified", async () => {
  await view("settings");
  await page.selectOption("#settings-motor", "7");
  await until(() => document.querySelector("#setting-position-kp .value")?.textContent.trim());
  await page.fill("#setting-position-kp input", "66");
  await page.click("#setting-position-kp .write button");
  await until(() => /ok|bad/.test(document.querySelector("#setting-position-kp .result").className));
  assert.match(await page.getAttribute("#setting-position-kp .result", "class"), /ok/);
  assert.match(JSON.stringify(simState()), /"kp":\s*66|"position_kp":\s*66/);
});

test("a step response shows its figures", async () => {
  await view("step");
  await page.selectOption("#step-motor", "12");
  await page.fill("#step-amplitude", "90");
  await page.fill("#step-duration", "1.5");
  await page.click("#step-run");
  await page.waitForFunction(() => /ms/.test(document.querySelector("#step-figures").textContent), null, {
    timeout: 60000,
  });
  const last = await page.evaluate(() => window.dashboard.lastStep);
  assert.ok(last.times.length > 5 && last.rise_time > 0, JSON.stringify(last).slice(0, 300));
  assert.equal(await page.locator("#step-runs tbody tr").count(), 1);
});

test("a browser backup is restored by `nurimc restore`, and a `nurimc backup` is restored in the browser", async () => {
  await view("backup");
  const downloaded = page.waitForEvent("download");
  await page.click("#backup");
  const file = join(DIR, "browser-backup.json");
  await (await downloaded).saveAs(file);
  const document_ = JSON.parse(readFileSync(file, "utf8"));
  assert.deepEqual(
    document_.motors.map((m) => [m.id, m.product]),
    [
      [3, "mc"],
      [7, "rsa"],
      [12, "mc"],
    ],
    "every motor, each in its own line",
  );
  assert.equal(document_.motors[0].settings["position-kp"], 77);
  // the CLI restores it: change kp behind the page's back first, so there is something to restore
  await page.evaluate(() => window.dashboard.link.request("watch", { ids: [] })); // the page's polling quiet
  await page.evaluate(() => window.dashboard.link.request("set", { id: 3, name: "position-kp", value: 40 }));
  const only3 = join(DIR, "browser-id3.json");
  writeFileSync(only3, JSON.stringify({ ...document_, motors: [document_.motors[0]] }, null, 2));
  const restored = await cli("restore", only3);
  assert.match(restored.stdout, /position-kp/);
  assert.match(JSON.stringify(simState()), /"kp":\s*77|"position_kp":\s*77/);
  // and the other way round
  const cliFile = join(DIR, "cli-backup.json");
  await cli("backup", cliFile);
  await page.evaluate(() => window.dashboard.link.request("set", { id: 3, name: "position-kp", value: 41 }));
  await page.setInputFiles("#restore-file", cliFile);
  await page.waitForFunction(() => /position-kp/.test(document.querySelector("#backup-text").textContent));
  const kp = await page.evaluate(
    async () => (await window.dashboard.link.request("read_settings", { id: 3 })).settings["position-kp"],
  );
  assert.equal(kp, 77);
  assert.equal(
    await page.evaluate(() => Object.keys(localStorage).filter((k) => k.startsWith("nurimc.restore")).length),
    0,
    "the journal is cleared",
  );
});

test("a garbled backup and a file of another product line are refused, nothing written", async () => {
  const before = await page
    .evaluate(async () => (await window.dashboard.link.request("read_settings", { id: 7 })).settings)
    .catch((e) => e.message);
  await page.setInputFiles("#restore-file", {
    name: "garbled.json",
    mimeType: "application/json",
    buffer: Buffer.from('{"format": "nurimc-backup/1", "motors": [{"id": 3, "se'),
  });
  await page.waitForFunction(() => /garbled\.json/.test(document.querySelector("#messages").textContent));
  const cliDoc = JSON.parse(readFileSync(join(DIR, "cli-backup.json"), "utf8"));
  const other = { ...cliDoc, motors: [{ ...cliDoc.motors[0], id: 7 }] }; // an MC backup onto the RSA
  await page.setInputFiles("#restore-file", {
    name: "other-line.json",
    mimeType: "application/json",
    buffer: Buffer.from(JSON.stringify(other)),
  });
  await page.waitForFunction(() => /another product line/.test(document.querySelector("#messages").textContent));
  assert.match(await messages(), /nothing was written/);
  const after = await page.evaluate(
    async () => (await window.dashboard.link.request("read_settings", { id: 7 })).settings,
  );
  assert.deepEqual(after, before, "the RSA's settings are as they were");
  assert.equal(
    await page.evaluate(() => Object.keys(localStorage).filter((k) => k.startsWith("nurimc.restore")).length),
    0,
  );
});

test("a restore left unfinished (the tab closed mid-restore) is said after the next discovery", async () => {
  // what restoreBackup leaves in localStorage when the page goes away between its mark and its end
  await page.evaluate(() =>
    localStorage.setItem("nurimc.restore.usb-1027-24577.id3", JSON.stringify({ file: "robot.json", since: 0 })),
  );
  await view("motors");
  await page.selectOption("#discover-rates", "57600");
  await page.click("#discover");
  await until(() => /incomplete restore of robot\.json/.test(document.querySelector("#messages").textContent));
  await page.evaluate(() => localStorage.removeItem("nurimc.restore.usb-1027-24577.id3"));
});

test("an ID change in the setup view, then the motor is found at its new ID", async () => {
  await view("setup");
  await page.selectOption("#setup-motor", "12");
  await page.fill("#new-id", "20");
  await page.click("#change-id");
  await page.waitForFunction(
    () =>
      /20/.test(document.querySelector("#setup-text").textContent) &&
      !/…|\.\.\./.test(document.querySelector("#setup-text").textContent),
  );
  await view("motors");
  await page.selectOption("#discover-rates", "250000");
  await page.click("#discover");
  await page.waitForFunction(() => document.querySelector("#discover-text").dataset.found === "20");
  assert.deepEqual(await page.$$eval(".card", (cards) => cards.map((c) => Number(c.dataset.id))), [3, 7, 20]);
});

test("a sequence runs in direct mode, across rates", async () => {
  await view("sequence");
  await page.evaluate(() =>
    window.dashboard.loadSequence({
      format: "nurimc-sequence/1",
      steps: [
        { kind: "move", id: 3, degrees: 10, rpm: 600 },
        { kind: "wait", seconds: 0.3 },
        { kind: "set", id: 20, name: "position-kp", value: 60 },
      ],
    }),
  );
  await page.click("#seq-run");
  await until(() => document.querySelector("#seq-status").dataset.state === "done", null, 60000);
  const kp = await page.evaluate(
    async () => (await window.dashboard.link.request("read_settings", { id: 20 })).settings["position-kp"],
  );
  assert.equal(kp, 60);
});

test("raw frames in direct mode: captured, and the exported traffic log is read by nurimc replay", async () => {
  await view("raw");
  await page.check("#raw-on");
  await page.evaluate(() => window.dashboard.link.request("release", { id: 3 }));
  await until(() =>
    [...document.querySelectorAll("#raw-table tbody td:nth-child(4) code")].some(
      (c) => c.textContent === "set_control",
    ),
  );
  const [download] = await Promise.all([page.waitForEvent("download"), page.click("#raw-export")]);
  const replayed = await run(NURIMC_BIN, ["replay", await download.path()]);
  assert.match(replayed.stdout, /set_control/);
  await page.uncheck("#raw-on");
});

test("the E-STOP turns every motor off, at every rate and in each line", async () => {
  await page.evaluate(() => window.dashboard.link.request("watch", { ids: [3, 7, 20] }));
  await page.click("#estop");
  await page.waitForFunction(() => (document.querySelector("#estop").dataset.lastResult ?? "").startsWith("{"), null, {
    timeout: 20000,
  });
  assert.deepEqual(JSON.parse(await page.getAttribute("#estop", "data-last-result")), {
    3: "off",
    7: "off",
    20: "off",
  });
});

test("the cable pulled as a gain is written: a clear message on the row, nothing written", async () => {
  await view("settings");
  await page.selectOption("#settings-motor", "3");
  await until(() => document.querySelector("#setting-position-kp .value")?.textContent.trim());
  const before = JSON.stringify(simState());
  await page.evaluate(() => window.__pullCable());
  await page.fill("#setting-position-kp input", "99");
  await page.click("#setting-position-kp .write button");
  await until(() => document.querySelector("#setting-position-kp .result").className.includes("bad"));
  assert.match(await page.textContent("#setting-position-kp .result"), /serial port|unplugged|closed/i);
  assert.equal(JSON.stringify(simState()), before, "nothing was written");
  assert.doesNotMatch(JSON.stringify(simState()), /"kp":\s*99|"position_kp":\s*99/);
});

test("installable; a reload with the server stopped still opens the page; a new version is picked up and said", async () => {
  const cdp = await page.context().newCDPSession(page);
  await page.evaluate(() => navigator.serviceWorker.ready);
  const { installabilityErrors } = await cdp.send("Page.getInstallabilityErrors");
  assert.deepEqual(installabilityErrors, [], "the manifest and service worker make it installable");
  const manifest = await page.evaluate(async () => (await fetch("./manifest.webmanifest")).json());
  assert.equal(manifest.display, "standalone");
  await page.waitForFunction(() => navigator.serviceWorker.controller !== null);
  server.stop();
  await new Promise((resolve) => server.child.once("exit", resolve));
  await page.reload();
  await page.waitForFunction(() => window.dashboard?.mode === "direct");
  assert.ok(await page.isVisible("#connect"), "the page opened from the kept copy");
  // a new version on the same address: picked up on the next load, and the page says so
  const next = join(DIR, "site-next");
  cpSync(SITE, next, { recursive: true });
  writeFileSync(join(next, "version.js"), 'export const VERSION = "next-version";\n');
  server = await serve(next, Number(new URL(url).port));
  await page.reload();
  await page.waitForFunction(() => document.documentElement.dataset.siteVersion === "next-version");
  await page.waitForFunction(() => /next-version/.test(document.querySelector("#messages").textContent));
});

test("a browser without navigator.serial (Firefox, Safari) sees which browsers work and the Python console", async () => {
  const other = await browser.newPage();
  await other.addInitScript(() => {
    delete Navigator.prototype.serial;
  });
  await other.goto(url);
  await other.waitForSelector("#unsupported");
  const text = await other.textContent("#unsupported");
  assert.match(text, /Chrome/);
  assert.match(text, /Edge/);
  assert.match(text, /nurimc dashboard/);
  await other.close();
  assert.deepEqual(
    problems.filter((p) => !/Failed to load resource/.test(p)),
    [],
  );
});
