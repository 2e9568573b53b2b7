// End-to-end tests of the console in headless Chromium against `nurimc dashboard --sim`.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { request as httpRequest } from "node:http";
import { existsSync, mkdirSync, mkdtempSync, readFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { ROOT, STATIC, startDashboard, launchBrowser, startStaticSite, discover } from "./lib.mjs";

// Screenshots go to docs/screenshots only when asked (make -f e2e/Makefile.inc screenshots),
// so an ordinary test run leaves the work tree clean.
const SHOTS = process.env.NURIMC_SCREENSHOTS ? join(ROOT, "docs/screenshots") : mkdtempSync(join(tmpdir(), "nurimc-shots-"));
let dashboard, browser, page;

before(async () => {
  mkdirSync(SHOTS, { recursive: true });
  [dashboard, browser] = await Promise.all([startDashboard(), launchBrowser()]);
  page = await browser.newPage();
  page.setDefaultTimeout(15000);
  page.on("pageerror", (error) => console.error("page error:", error.message));
  await page.goto(dashboard.url);
  await page.waitForFunction(() => window.dashboard?.mode);
});

after(async () => {
  await browser?.close();
  dashboard?.stop();
});

const motorPosition = (id) => page.evaluate((id) => window.dashboard.motors.get(id)?.series.position.at(-1), id);

test("the page discovers the simulated motors, showing progress", async () => {
  assert.match(await page.textContent("#mode"), /server/);
  const found = await discover(page);
  assert.deepEqual(found, [1, 2, 3]);
  assert.ok((await page.evaluate(() => window.dashboard.progressEvents)) > 1, "progress events were shown");
  assert.equal(await page.locator(".card").count(), 3);
});

test("a move shows in the live plot", async () => {
  await page.waitForFunction(() => window.dashboard.motors.get(1)?.series.t.length > 5);
  const before = await motorPosition(1);
  const card = page.locator("#motor-1");
  await card.locator(".controls").first().locator("input[type=number]").nth(0).fill(String(Math.round(before + 120)));
  await card.locator(".controls").first().locator("input[type=number]").nth(1).fill("240");
  await card.getByRole("button", { name: "Move" }).click();
  await page.waitForFunction((target) => Math.abs(window.dashboard.motors.get(1).series.position.at(-1) - target) < 2, before + 120, { timeout: 20000 });
  const plotted = await page.evaluate(() => window.dashboard.motors.get(1).plot.data[1]);
  assert.ok(Math.max(...plotted) - Math.min(...plotted) > 100, "the plotted positions span the move");
  assert.ok(Math.abs(Number(await card.getAttribute("data-last-position")) - (before + 120)) < 2);
  await page.screenshot({ path: join(SHOTS, "motors.png") });
});

test("a setting change is written, verified and shown", async () => {
  await page.click("nav button[data-view=settings]");
  await page.selectOption("#settings-motor", "2");
  await page.waitForFunction(() => window.dashboard.settingsShownFor === 2);
  const row = page.locator("#setting-position-kp");
  await row.locator("input").fill("77");
  await row.getByRole("button", { name: "Write" }).click();
  await assert.doesNotReject(row.locator(".result.ok").waitFor({ timeout: 10000 }));
  assert.match(await row.locator(".result").textContent(), /verified: 77/);
  await row.locator(".value").evaluate((cell) => { cell.textContent = ""; });
  await page.click("#settings-read");  // read back from the controller, not from the page
  await page.waitForFunction(() => document.querySelector("#setting-position-kp .value").textContent === "77");
  const out = page.locator("#setting-position-kp");
  await out.locator("input").fill("300");
  await out.getByRole("button", { name: "Write" }).click();
  await out.locator(".result.bad").waitFor();
  assert.match(await out.locator(".result").textContent(), /out of range; allowed: 1\.\.254/);
  await page.screenshot({ path: join(SHOTS, "settings.png") });
});

test("the step-response tool plots target and actual and reports the figures", async () => {
  await page.click("nav button[data-view=step]");
  await page.selectOption("#step-motor", "1");
  await page.fill("#step-amplitude", "-90");
  await page.fill("#step-duration", "1.5");
  await page.click("#step-run");
  await page.waitForFunction(() => window.dashboard.lastStep, null, { timeout: 20000 });
  const step = await page.evaluate(() => window.dashboard.lastStep);
  // the target is start - 90 on the wire's 0.01 deg grid; compare within half a step, not float bits
  assert.ok(Math.abs(step.target - (step.start - 90)) <= 0.005, `target ${step.target} is start ${step.start} - 90`);
  assert.ok(step.rise_time > 0, "rise time measured");
  assert.match(await page.textContent("#step-figures"), /rise time .* overshoot/);
  await page.screenshot({ path: join(SHOTS, "step-response.png") });
});

test("the raw view shows decoded frames, filterable", async () => {
  await page.click("nav button[data-view=raw]");
  await page.check("#raw-on");
  await page.waitForFunction(() => window.dashboard.frames.length > 20);
  await page.fill("#raw-filter", "id=1 position_feedback");
  await page.waitForFunction(() => document.querySelectorAll("#raw-table tbody tr").length > 0);
  const names = await page.locator("#raw-table tbody tr td:nth-child(4)").allTextContents();
  assert.ok(names.every((name) => name === "position_feedback"), names.join(","));
  await page.screenshot({ path: join(SHOTS, "raw-frames.png") });
  await page.uncheck("#raw-on");
});

test("the emergency stop releases every motor on the bus", async () => {
  await page.click("nav button[data-view=motors]");
  for (const id of [1, 2, 3]) {
    await page.locator(`#motor-${id}`).getByRole("button", { name: "Run" }).click();
  }
  await page.waitForFunction(() => [1, 2, 3].every((id) => Math.abs(window.dashboard.motors.get(id).series.speed.at(-1)) > 5), null, { timeout: 20000 });
  await page.click("#estop");
  await page.waitForFunction(() => document.querySelector("#estop").dataset.lastResult, null, { timeout: 20000 });
  // Independently of the page's display: ask the server to read each controller's control setting.
  const controls = await page.evaluate(async () => {
    const out = {};
    for (const id of [1, 2, 3]) out[id] = (await window.dashboard.link.request("read_settings", { id })).settings.control;
    return out;
  });
  assert.deepEqual(controls, { 1: "off", 2: "off", 3: "off" });
  const shown = await page.evaluate(() => [...document.querySelectorAll(".card")].map((card) => card.dataset.control));
  assert.deepEqual(shown, ["off", "off", "off"], await page.getAttribute("#estop", "data-last-result"));
});

function handshake(url, headers) {
  const { host, port } = new URL(url);
  return new Promise((resolve, reject) => {
    const req = httpRequest({ host: "127.0.0.1", port, path: "/ws", headers: {
      Connection: "Upgrade", Upgrade: "websocket", "Sec-WebSocket-Version": "13", "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==", Host: host, ...headers } });
    req.on("upgrade", (response, socket) => { socket.destroy(); resolve(response.statusCode); });
    req.on("response", (response) => { response.resume(); resolve(response.statusCode); });
    req.on("error", reject);
    req.end();
  });
}

test("a cross-origin websocket is refused; the console's own origin is accepted", async () => {
  const own = new URL(dashboard.url);
  assert.equal(await handshake(dashboard.url, { Origin: `http://${own.host}` }), 101);
  assert.equal(await handshake(dashboard.url, { Origin: "http://evil.example" }), 403);
  assert.equal(await handshake(dashboard.url, {}), 403, "no Origin");
  assert.equal(await handshake(dashboard.url, { Origin: "http://evil.example", Host: "evil.example" }), 403, "rebinding Host");
});

test("direct mode: without the server the page offers Web Serial through the TypeScript library", async () => {
  const bundle = join(ROOT, "ts/dist/nurimc.browser.js");
  assert.ok(existsSync(bundle), "ts/dist/nurimc.browser.js is built by `make -f ts/Makefile.inc ts-build`");
  const site = await startStaticSite(bundle);
  try {
    const direct = await browser.newPage();
    direct.setDefaultTimeout(15000);
    await direct.goto(site.url);
    await direct.waitForFunction(() => window.dashboard.mode === "direct" && document.querySelector("#status").textContent);
    assert.match(await direct.textContent("#mode"), /direct/);
    assert.ok(await direct.isVisible("#connect"));
    assert.equal(await direct.evaluate(() => typeof window.dashboard.lib.Bus), "function");
    assert.equal(await direct.evaluate(() => typeof window.dashboard.lib.WebSerialPort), "function");
    const hasSerial = await direct.evaluate(() => "serial" in navigator);
    assert.equal(await direct.isEnabled("#connect"), hasSerial);
    await direct.screenshot({ path: join(SHOTS, "direct-mode.png") });
    await direct.close();
  } finally {
    site.stop();
  }
});

test("the uPlot copied from npm next to the page is the version e2e/package.json pins", () => {
  const pinned = JSON.parse(readFileSync(join(ROOT, "e2e/node_modules/uplot/package.json"))).version;
  assert.equal(readFileSync(join(STATIC, "vendor/uplot/VERSION"), "utf8").trim(), pinned);
  assert.deepEqual(readFileSync(join(STATIC, "vendor/uplot/uPlot.esm.js")), readFileSync(join(ROOT, "e2e/node_modules/uplot/dist/uPlot.esm.js")));
});
