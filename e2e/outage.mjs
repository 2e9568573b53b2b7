// End-to-end: the console across a port outage, in headless Chromium against a real
// `nurimc --port <pty> dashboard` whose pty is served by the fault proxy in front of the
// simulator (python -m nurimc.sim.faultproxy: SIGUSR1 cuts, SIGUSR2 restores). No fixed sleeps:
// every step waits for what the page shows.
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import { mkdirSync, mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join } from "node:path";
import { after, before, test } from "node:test";
import { launchBrowser, NURIMC_BIN, ROOT, startFaultProxy, startPortDashboard, startSimulator } from "./lib.mjs";

const SHOTS = process.env.NURIMC_SCREENSHOTS
  ? join(ROOT, "docs/screenshots")
  : mkdtempSync(join(tmpdir(), "nurimc-shots-"));
const BAUD = 115200;
const dir = mkdtempSync(join(tmpdir(), "nurimc-outage-"));
let sim, proxy, otherSim, otherProxy, dashboard, browser, page;
const problems = [];

/** Find the motors once at the simulator's rate, from outside (the page then shows them at once). */
function discoverAt(url) {
  const script = `
import asyncio, json, sys, websockets
async def main(url):
    async with websockets.connect(url.replace("http", "ws") + "ws", origin=url.rstrip("/")) as ws:
        await ws.recv()
        await ws.send(json.dumps({"op": "discover", "req": 1, "gen": 0, "rates": [${BAUD}]}))
        while True:
            m = json.loads(await ws.recv())
            if m.get("type") == "reply":
                print(json.dumps(m))
                return
asyncio.run(main(sys.argv[1]))
`;
  const run = spawnSync(join(dirname(NURIMC_BIN), "python"), ["-c", script, url], { encoding: "utf8", timeout: 30000 });
  assert.equal(run.status, 0, run.stderr);
  const reply = JSON.parse(run.stdout);
  assert.deepEqual(
    reply.result.known.map((m) => m.id),
    [1, 2],
    run.stdout,
  );
}

async function openPage(viewport) {
  const p = await browser.newPage();
  p.setDefaultTimeout(60000);
  if (viewport) await p.setViewportSize(viewport);
  p.on("pageerror", (error) => problems.push(`page error: ${error.message}`));
  p.on("console", (m) => {
    if (m.type() === "error") problems.push(`console: ${m.text()}`);
  });
  await p.goto(dashboard.url);
  await p.waitForFunction(() => window.dashboard?.connected && document.querySelectorAll(".card").length === 2);
  return p;
}

const controls = (p) =>
  p.evaluate(async () => {
    const out = {};
    for (const id of [1, 2]) out[id] = (await window.dashboard.link.request("read_settings", { id })).settings.control;
    return out;
  });

/** Elements poking out of the viewport's width (hidden ones and list options aside). */
const offScreen = (p, width) =>
  p.evaluate((width) => {
    const out = [];
    for (const e of document.body.querySelectorAll("*")) {
      if (e.closest(".hidden") || e.tagName === "OPTION" || e.tagName === "SCRIPT") continue;
      const r = e.getBoundingClientRect();
      if (r.width === 0 || r.height === 0) continue;
      if (r.left < -1 || r.right > width + 1)
        out.push(`${e.tagName.toLowerCase()}#${e.id}.${e.className} ${Math.round(r.left)}..${Math.round(r.right)}`);
    }
    return out.slice(0, 10);
  }, width);

before(async () => {
  mkdirSync(SHOTS, { recursive: true });
  [sim, otherSim, browser] = await Promise.all([
    startSimulator("1,2", BAUD),
    startSimulator("3", BAUD),
    launchBrowser(),
  ]);
  [proxy, otherProxy] = await Promise.all([
    startFaultProxy(sim.port, join(dir, "ttyCut")),
    startFaultProxy(otherSim.port, join(dir, "ttyOther")),
  ]);
  dashboard = await startPortDashboard(proxy.link, BAUD);
  discoverAt(dashboard.url);
  page = await openPage();
});

after(async () => {
  await browser?.close();
  for (const child of [dashboard, otherProxy, proxy, otherSim, sim]) child?.stop();
});

test("cut: 'port lost … reconnecting' with how long, badges not answering; E-STOP: 'stop pending: port lost'; restore: banner clears, stop confirmed, motors off", async () => {
  await page.locator("#motor-1").getByRole("button", { name: "Run" }).click();
  await page.waitForFunction(() => Math.abs(window.dashboard.motors.get(1).series.speed.at(-1)) > 5);
  assert.ok(await page.locator("#port-banner").isHidden(), "no port banner while the port is up");

  await proxy.cut();
  await page.waitForSelector("#port-banner:not(.hidden)");
  const banner = page.locator("#port-banner-text");
  assert.match(await banner.textContent(), /^port lost: .*ttyCut — reconnecting \(down \d+ s\)$/);
  await page.waitForFunction(() => /\(down [1-9]\d* s\)/.test(document.querySelector("#port-banner-text").textContent));
  await page.waitForFunction(() =>
    [1, 2].every((id) => document.querySelector(`#motor-${id} .state`).textContent === "not answering"),
  );
  assert.equal(await page.getAttribute("#motor-1", "data-state"), "silent");
  assert.equal(await page.textContent("#status"), "server connected · port lost");
  assert.match(await page.getAttribute("#motor-1 .state", "title"), /port is lost/);
  // the page can still ask: a command is refused at once with the reason, in words
  await page.locator("#motor-2").getByRole("button", { name: "Hold" }).click();
  await page.waitForFunction(() =>
    [...document.querySelectorAll("#messages .message .text")].some((e) => /hold.*is lost/i.test(e.textContent)),
  );

  await page.click("#estop");
  await page.waitForSelector("#stop-banner[data-state=pending]");
  assert.match(await page.textContent("#stop-banner-text"), /^stop pending: port lost/);
  assert.ok(await page.locator("#stop-banner-close").isHidden(), "no way to dismiss a pending stop");
  assert.equal(await page.getAttribute("#estop", "data-last-result"), "pending");
  assert.ok(await page.locator("#banner").isHidden(), "no 'E-STOP failed' alarm: it is latched, not failed");
  // a page opened during the outage sees both at once (hello's port_state)
  const late = await openPage();
  await late.waitForSelector("#port-banner:not(.hidden)");
  await late.waitForSelector("#stop-banner[data-state=pending]");
  assert.match(await late.textContent("#port-banner-text"), /^port lost: .*ttyCut/);
  await late.close();
  await page.screenshot({ path: join(SHOTS, "port-lost.png") });

  await proxy.restore();
  await page.waitForSelector("#stop-banner[data-state=done]", { timeout: 60000 });
  assert.match(await page.textContent("#stop-banner-text"), /^STOPPED after the port returned/);
  await page.waitForSelector("#port-banner.hidden", { state: "attached" });
  await page.waitForFunction(() =>
    [...document.querySelectorAll("#messages .message .text")].some((e) =>
      /port .*ttyCut back after/.test(e.textContent),
    ),
  );
  for (const id of [1, 2]) assert.equal(await page.getAttribute(`#motor-${id}`, "data-control"), "off");
  assert.notEqual(await page.getAttribute("#estop", "data-last-result"), "pending");
  assert.deepEqual(JSON.parse(await page.getAttribute("#estop", "data-last-result")), { 1: "off", 2: "off" });
  assert.deepEqual(await controls(page), { 1: "off", 2: "off" }, "read back from the motors");
  assert.equal(await page.textContent("#status"), "connected");
  // fresh readings again: the badges say stopped, not "not answering"
  await page.waitForFunction(() =>
    [1, 2].every((id) => document.querySelector(`#motor-${id}`).dataset.state === "stopped"),
  );
});

test("phone 390x844: the port banner and the pending stop fit on the screen, nothing off-screen", async () => {
  await proxy.cut();
  await page.waitForSelector("#port-banner:not(.hidden)");
  const phone = await openPage({ width: 390, height: 844 });
  try {
    await phone.waitForSelector("#port-banner:not(.hidden)");
    await phone.click("#estop");
    await phone.waitForSelector("#stop-banner[data-state=pending]");
    const width = await phone.evaluate(() => document.documentElement.scrollWidth);
    assert.ok(width <= 390, `page is ${width} px wide`);
    assert.deepEqual(await offScreen(phone, 390), [], "elements off-screen");
    for (const selector of ["#port-banner", "#stop-banner", "#port-reopen", "#port-choose"]) {
      const box = await phone.locator(selector).boundingBox();
      assert.ok(
        box.x >= 0 && box.x + box.width <= 390 && box.y >= 0 && box.y + box.height <= 844,
        `${selector} on screen`,
      );
    }
    for (const selector of ["#port-reopen", "#port-choose"]) {
      const box = await phone.locator(selector).boundingBox();
      assert.ok(box.height >= 40 && box.width >= 40, `${selector} is a 40 px target`);
    }
    await phone.screenshot({ path: join(SHOTS, "phone-port-lost.png") });
    // in Korean: the same banners in the vendor's words, still on the screen
    await phone.evaluate(() => window.dashboard.setLanguage("ko"));
    try {
      assert.match(await phone.textContent("#port-banner-text"), /^포트 끊김: .*ttyCut — 다시 연결하는 중/);
      assert.match(await phone.textContent("#stop-banner-text"), /^정지 대기: 포트 끊김/);
      assert.equal(await phone.textContent("#motor-1 .state"), "응답 없음");
      assert.deepEqual(await offScreen(phone, 390), [], "elements off-screen (Korean)");
    } finally {
      await phone.evaluate(() => window.dashboard.setLanguage("en")); // the pick is remembered by the browser
    }
  } finally {
    await phone.close();
  }
});

test("while lost, the page reopens the same path (the reason if it is not back) or opens another path, carrying out the latched stop there", async () => {
  // still cut from the phone test, with its stop latched
  await page.waitForSelector("#port-banner:not(.hidden)");
  await page.click("#port-reopen");
  await page.waitForFunction(() => /cannot reopen/.test(document.querySelector("#port-banner-detail").textContent));
  assert.ok(await page.locator("#port-banner").isVisible(), "still lost");

  await page.click("#port-choose");
  await page.waitForSelector("#view-setup:not(.hidden)");
  await page.waitForFunction(() => /^port lost: .*ttyCut/.test(document.querySelector("#bus-text").textContent));
  await page.fill("#bus-path", otherProxy.link);
  await page.click("#bus-open");
  await page.waitForFunction(
    (link) => document.querySelector("#bus-text").textContent.startsWith(`open: ${link} at`),
    otherProxy.link,
  );
  await page.waitForSelector("#port-banner.hidden", { state: "attached" });
  await page.waitForSelector("#stop-banner[data-state=done]");
  assert.equal(await page.inputValue("#bus-path"), "", "the typed path is taken");
  assert.equal(await page.evaluate(() => window.dashboard.port.port), otherProxy.link);
});

test("the browser console stayed clean", () => {
  assert.deepEqual(problems, []);
});
