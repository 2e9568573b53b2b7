// End-to-end tests of the console in headless Chromium against `nurimc dashboard --sim`.

import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import { existsSync, mkdirSync, mkdtempSync, readFileSync } from "node:fs";
import { request as httpRequest } from "node:http";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { after, before, test } from "node:test";
import {
  countPixels,
  discover,
  launchBrowser,
  NURIMC_BIN,
  openConsole,
  ROOT,
  STATIC,
  startDashboard,
  startStaticSite,
} from "./lib.mjs";
import { startBridge, startPtySimulator } from "./serial-bridge.mjs";

// Screenshots go to docs/screenshots only when asked (make -f e2e/Makefile.inc screenshots),
// so an ordinary test run leaves the work tree clean.
const SHOTS = process.env.NURIMC_SCREENSHOTS
  ? join(ROOT, "docs/screenshots")
  : mkdtempSync(join(tmpdir(), "nurimc-shots-"));
let dashboard, browser, page;
const problems = []; // console errors, page errors and failed loads of the main page

// Before any page script: log every websocket op the page sends, and whether a card showed
// while discovery was still running.
const SPY = () => {
  window.sentOps = [];
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    try {
      window.sentOps.push(JSON.parse(data).op);
    } catch {
      /* not ours */
    }
    return send.call(this, data);
  };
  new MutationObserver(() => {
    const text = document.querySelector("#discover-text");
    if (document.querySelector(".card") && text && !text.dataset.found) window.cardBeforeScanEnded = true;
  }).observe(document, { childList: true, subtree: true });
};

function watch(p, sink) {
  p.on("console", (m) => {
    if (m.type() === "error") sink.push(`console: ${m.text()}`);
  });
  p.on("pageerror", (error) => sink.push(`page error: ${error.message}`));
  p.on("response", (r) => {
    if (r.status() >= 400) sink.push(`HTTP ${r.status()} ${r.url()}`);
  });
}

before(async () => {
  mkdirSync(SHOTS, { recursive: true });
  [dashboard, browser] = await Promise.all([startDashboard(), launchBrowser()]);
  // the first page of a server that knows no motors discovers them (the first test looks at it)
  page = await browser.newPage();
  page.setDefaultTimeout(60000);
  await page.addInitScript(SPY);
  watch(page, problems);
  await page.goto(dashboard.url);
  await page.waitForFunction(() => window.dashboard?.mode);
  await discover(page);
});

after(async () => {
  await browser?.close();
  dashboard?.stop();
});

/** A page of its own for a test: the console with its three motor cards, the spy installed, problems watched. */
async function fresh(options = {}) {
  const p = await openConsole(browser, dashboard.url, { init: SPY, ...options });
  watch(p, problems);
  return p;
}
/** Wait until `n` more samples have come in (time passing, measured by the live data, not a fixed sleep). */
async function afterSamples(p, n) {
  const now = await p.evaluate(() => window.dashboard.samplesReceived);
  await p.waitForFunction(([now, n]) => window.dashboard.samplesReceived >= now + n, [now, n]);
}
const shot = (p, name) => p.screenshot({ path: join(SHOTS, name) });

const motorPosition = (p, id) => p.evaluate((id) => window.dashboard.motors.get(id)?.series.position.at(-1), id);
const controls = (p) =>
  p.evaluate(async () => {
    const out = {};
    for (const id of [...window.dashboard.motors.keys()])
      out[id] = (await window.dashboard.link.request("read_settings", { id })).settings.control;
    return out;
  });
const lastToast = (p) =>
  p.evaluate(() => document.querySelector("#messages .message:last-child .text")?.textContent ?? "");

test("the first load discovers the motors by itself, cards appearing as they are found", async () => {
  assert.match(await page.textContent("#mode"), /server/);
  const found = await discover(page);
  assert.deepEqual(found, [1, 2, 3]);
  assert.ok((await page.evaluate(() => window.dashboard.progressEvents)) > 1, "progress events were shown");
  assert.equal(await page.evaluate(() => window.cardBeforeScanEnded), true, "a card showed before the scan ended");
  assert.equal(await page.locator(".card").count(), 3);
  assert.match(await page.textContent(".hint"), /Esc.*emergency stop/, "the Escape key is documented on the page");
  assert.match(await page.getAttribute("#estop", "title"), /Esc/);
  assert.equal(await page.evaluate(() => getComputedStyle(document.querySelector("#top")).position), "sticky");
  assert.equal(
    await page.evaluate(() => getComputedStyle(document.querySelector("#estop")).backgroundColor),
    "rgb(192, 38, 45)",
    "the E-STOP is red",
  );
});

test("a move shows in the live plot, with its target, on a time axis relative to now", async () => {
  const page = await fresh();
  try {
    await page.waitForFunction(() => window.dashboard.motors.get(1)?.series.t.length > 5);
    const before = await motorPosition(page, 1);
    const card = page.locator("#motor-1");
    await card
      .locator(".controls")
      .first()
      .locator("input[type=number]")
      .nth(0)
      .fill(String(Math.round(before + 120)));
    await card.locator(".controls").first().locator("input[type=number]").nth(1).fill("240");
    await card.getByRole("button", { name: "Move" }).click();
    await page.waitForFunction(
      (target) => Math.abs(window.dashboard.motors.get(1).series.position.at(-1) - target) < 2,
      before + 120,
      { timeout: 60000 },
    );
    await afterSamples(page, 30);
    // the card's plot is drawn at its own pace (a busy host draws later): wait for it to show the move
    await page.waitForFunction(
      () => {
        const [, positions] = window.dashboard.motors.get(1).plot.data;
        return positions.length > 0 && Math.max(...positions) - Math.min(...positions) > 100;
      },
      undefined,
      { timeout: 60000 },
    );
    const plotted = await page.evaluate(() => window.dashboard.motors.get(1).plot.data);
    assert.ok(Math.max(...plotted[1]) - Math.min(...plotted[1]) > 100, "the plotted positions span the move");
    assert.ok(
      plotted[2].some((v) => v != null && Math.abs(v - (before + 120)) < 0.5),
      "the target is drawn",
    );
    assert.ok(plotted[0].at(-1) === 0 && plotted[0][0] < 0, "time runs up to 0 = now");
    assert.ok(Math.abs(Number(await card.getAttribute("data-last-position")) - (before + 120)) < 2);
    assert.ok(
      Math.abs(Number(await card.getAttribute("data-device-position"))) <= 655.35,
      "the device's own position is shown",
    );
    assert.match(await card.locator(".readout").textContent(), /position -?[\d,]+\.\d+ °.*device -?[\d,]+\.\d+ °/s);
    const axes = await page.evaluate(() => {
      const u = window.dashboard.motors.get(1).plot;
      return u.axes.slice(1).map((a) => `${a.scale}:${a.label}`);
    });
    assert.deepEqual(axes, ["deg:°"], "the card's plot: position and target on one axis (the Plot view has the rest)");
    assert.match(
      await card.locator(".state").textContent(),
      /^(on|moving)$/,
      "the card says the motor is on or moving",
    );
  } finally {
    await page.close();
  }
});

test("a live plot pauses, holds a zoom, shows values on hover and exports CSV", async () => {
  const page = await fresh();
  try {
    const card = page.locator("#motor-1");
    await card.getByRole("button", { name: "Pause" }).click();
    const frozen = await page.evaluate(() => window.dashboard.motors.get(1).plot.data[0].length);
    await afterSamples(page, 100);
    assert.equal(
      await page.evaluate(() => window.dashboard.motors.get(1).plot.data[0].length),
      frozen,
      "paused: no new data drawn",
    );
    await card.getByRole("button", { name: "Resume" }).click();
    const over = card.locator(".u-over");
    const box = await over.boundingBox();
    await page.mouse.move(box.x + box.width * 0.3, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width * 0.6, box.y + box.height / 2, { steps: 5 });
    await page.mouse.up();
    const zoomed = await page.evaluate(() => {
      const u = window.dashboard.motors.get(1).plot;
      return [u.scales.x.min, u.scales.x.max];
    });
    await afterSamples(page, 120);
    const held = await page.evaluate(() => {
      const u = window.dashboard.motors.get(1).plot;
      return [u.scales.x.min, u.scales.x.max];
    });
    assert.deepEqual(held, zoomed, "the zoom holds");
    await page.mouse.move(box.x + box.width * 0.5, box.y + box.height / 2);
    assert.match(await card.locator(".u-legend").textContent(), /\d+\.\d+ s/, "hover shows values");
    await over.dblclick();
    assert.equal(await card.getAttribute("data-paused"), "no", "double-click resumes");
    const [download] = await Promise.all([
      page.waitForEvent("download"),
      card.getByRole("button", { name: "CSV" }).click(),
    ]);
    const csv = readFileSync(await download.path(), "utf8");
    assert.match(
      csv.split("\n")[0],
      /^t_s,position_deg,device_position_deg,speed_rpm,current_a,target_deg,position_uncertain$/,
    );
    assert.ok(csv.split("\n").length > 10);
  } finally {
    await page.close();
  }
});

test("blank, text, huge and negative fields are refused on the page; nothing is sent", async () => {
  const page = await fresh();
  try {
    const card = page.locator("#motor-2");
    const [to, rpm] = [
      card.locator(".controls").first().locator("input").nth(0),
      card.locator(".controls").first().locator("input").nth(1),
    ];
    const before = await motorPosition(page, 2);
    const sent = () => page.evaluate(() => window.sentOps.filter((op) => op === "move").length);
    const moves = await sent();
    for (const [target, speed, says] of [
      ["", "60", /to: empty/],
      ["1e400", "60", /to: not a (finite )?number/],
      ["90", "-60", /must be above 0/],
      ["90", "", /move RPM: empty/],
    ]) {
      await to.fill(target);
      await rpm.fill(speed);
      await card.getByRole("button", { name: "Move" }).click();
      await page.waitForFunction(() => document.querySelector("[aria-invalid=true]"));
      assert.match(await lastToast(page), says);
    }
    await to.evaluate((input) => {
      input.type = "text";
      input.value = "ninety";
    }); // what a browser without number inputs sends
    await rpm.fill("60");
    await card.getByRole("button", { name: "Move" }).click();
    assert.match(await lastToast(page), /"ninety" is not a number/);
    await to.evaluate((input) => {
      input.type = "number";
    });
    assert.equal(await sent(), moves, "no move went out");
    assert.ok(Math.abs((await motorPosition(page, 2)) - before) < 1, "the motor stayed where it was");
    const close = page.locator("#messages .message .close").first();
    const count = await page.locator("#messages .message").count();
    await close.click();
    assert.equal(await page.locator("#messages .message").count(), count - 1, "a message can be closed");
    assert.ok(count <= 4, "messages do not pile up");
  } finally {
    await page.close();
  }
});

test("a move past the device's ±655.33° is refused with the reason, on the page and by the server; Set zero", async () => {
  const page = await fresh();
  try {
    const card = page.locator("#motor-1");
    const [to, rpm] = [0, 1].map((n) => card.locator(".controls").first().locator("input").nth(n));
    const moves = await page.evaluate(() => window.sentOps.filter((op) => op === "move").length);
    await to.fill("700");
    await rpm.fill("60");
    await card.getByRole("button", { name: "Move" }).click();
    assert.match(await lastToast(page), /outside the device's range ±655\.33°.*Set zero/);
    assert.equal(await page.evaluate(() => window.sentOps.filter((op) => op === "move").length), moves);
    const server = await page.evaluate(() =>
      window.dashboard.link.request("move", { id: 1, degrees: 700, rpm: 60 }).then(
        () => "moved",
        (error) => error.message,
      ),
    );
    assert.match(server, /655\.33/, "the server refuses it too, and says why");
    await card.getByRole("button", { name: "Set zero" }).click();
    await page.waitForFunction(() => /now 0°/.test(document.querySelector("#messages").textContent));
    await page.waitForFunction(
      () => Math.abs(Number(document.querySelector("#motor-1").dataset.devicePosition)) < 1,
      null,
      { timeout: 60000 },
    );
  } finally {
    await page.close();
  }
});

test("a setting change is written, verified and shown", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=settings]");
    await page.selectOption("#settings-motor", "2");
    await page.waitForFunction(() => window.dashboard.settingsShownFor === 2);
    const row = page.locator("#setting-position-kp");
    await row.locator("input").fill("77");
    await row.getByRole("button", { name: "Write" }).click();
    // the motor's badge says it is busy writing its settings, then no longer
    await page.waitForFunction(() => document.querySelector("#motor-2").dataset.state === "busy");
    await page.waitForFunction(() => !["busy", undefined].includes(document.querySelector("#motor-2").dataset.state));
    await assert.doesNotReject(row.locator(".result.ok").waitFor({ timeout: 60000 }));
    assert.match(await row.locator(".result").textContent(), /verified: 77/);
    await row.locator(".value").evaluate((cell) => {
      cell.textContent = "";
    });
    await page.click("#settings-read"); // read back from the controller, not from the page
    await page.waitForFunction(() => document.querySelector("#setting-position-kp .value").textContent === "77");
    await row.locator("input").fill("");
    await row.getByRole("button", { name: "Write" }).click();
    await row.locator(".result.bad").waitFor();
    assert.match(await row.locator(".result").textContent(), /empty/);
    await row.locator("input").fill("300");
    await row.getByRole("button", { name: "Write" }).click();
    await page.waitForFunction(() =>
      /out of range/.test(document.querySelector("#setting-position-kp .result").textContent),
    );
  } finally {
    await page.close();
  }
});

test("the step tool prefills the gains, draws while it records, overlays runs in a table, compares A/B, writes every gain", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=step]");
    await page.waitForFunction(() => window.dashboard.gainsShownFor != null);
    await page.selectOption("#step-motor", "1");
    await page.waitForFunction(() => window.dashboard.gainsShownFor === 1);
    assert.notEqual(await page.inputValue("#gain-kp"), "", "Kp read from the motor");
    await page.fill("#step-amplitude", "-90");
    await page.fill("#step-duration", "2");
    await page.click("#step-run");
    // while it records: the live trace is drawn (red), before the server's answer arrives
    await page.waitForFunction(() => Number(document.querySelector("#step-plot").dataset.points) > 20, null, {
      timeout: 60000,
    });
    const drawing = await countPixels(page, "#step-plot", ["#b91c1c"]);
    assert.equal(await page.evaluate(() => window.dashboard.stepRuns.length), 0, "still recording");
    assert.ok(drawing["#b91c1c"] > 100, `the live trace is drawn while recording: ${JSON.stringify(drawing)}`);
    await page.waitForFunction(() => window.dashboard.stepRuns.length === 1, null, { timeout: 60000 });
    await page.fill("#step-duration", "0.6");
    await page.click("#step-run");
    await page.waitForFunction(() => window.dashboard.stepRuns.length === 2, null, { timeout: 60000 });
    const step = await page.evaluate(() => window.dashboard.lastStep);
    assert.ok(Math.abs(step.target - (step.start - 90)) <= 0.005, `target ${step.target} is start ${step.start} - 90`);
    assert.ok(step.rise_time > 0, "rise time measured");
    assert.match(await page.textContent("#step-figures"), /rise time .* overshoot.*settling.*final error/);
    assert.equal(await page.locator("#step-plot .u-legend .u-series").count(), 4, "t, target and both runs");
    const rows = await page.locator("#step-runs tbody tr").allTextContents();
    assert.equal(rows.length, 2, "a row per run");
    assert.ok(
      rows.every((row) => /ID 1.*\d+ \/ \d+ \/ \d+.*ms.*%/.test(row)),
      rows.join("\n"),
    );
    const runPixels = await countPixels(page, "#step-plot", ["#2457c5", "#d97706"]);
    assert.ok(
      Object.values(runPixels).every((n) => n > 100),
      `both runs drawn: ${JSON.stringify(runPixels)}`,
    );
    await page.locator("#step-runs tbody tr").nth(0).locator("td.ab input").nth(0).check();
    await page.locator("#step-runs tbody tr").nth(1).locator("td.ab input").nth(1).check();
    assert.match(await page.textContent("#step-ab"), /B \(#2\) − A \(#1\): rise/);
    const kp = Number(await page.inputValue("#gain-kp"));
    await page.fill("#gain-kp", String(kp === 254 ? 253 : kp + 1));
    await page.click("#gains-write");
    await page.waitForFunction(() =>
      /each written and verified/.test(document.querySelector("#gains-text").textContent),
    );
    assert.match(await page.textContent("#gains-text"), /Kp = \d+, .*Ki = \d+, .*Kd = \d+/, "every gain reported");
    await page.fill("#gain-kp", String(kp));
    await page.evaluate(() => {
      document.querySelector("#gains-text").textContent = "";
    });
    await page.click("#gains-write");
    await page.waitForFunction(() =>
      /each written and verified/.test(document.querySelector("#gains-text").textContent),
    );
  } finally {
    await page.close();
  }
});

test("raw frames: the console's polling hidden by default, filters by ID, message and direction, pause, a log replay reads", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=raw]");
    await page.check("#raw-on");
    await page.waitForFunction(() => window.dashboard.frames.length > 20);
    const shown = () => page.locator("#raw-table tbody tr td:nth-child(4) code").allTextContents();
    // the page's own polling (request_position / position_feedback) is hidden until asked for
    await page.waitForFunction(() => /of [\d,]+ frames/.test(document.querySelector("#raw-count").textContent));
    assert.ok((await shown()).every((name) => !["request_position", "position_feedback"].includes(name)));
    const card = page.locator("#motor-2");
    await page.click("nav button[data-view=motors]");
    await card.getByRole("button", { name: "Hold" }).click();
    await page.click("nav button[data-view=raw]");
    await page.waitForFunction(() =>
      [...document.querySelectorAll("#raw-table tbody td:nth-child(4) code")].some(
        (code) => code.textContent === "set_control",
      ),
    );
    await page.check("#raw-polling");
    await page.fill("#raw-id", "1");
    await page.selectOption("#raw-message", "position_feedback");
    await page.selectOption("#raw-dir", "rx");
    await page.waitForFunction(() => document.querySelectorAll("#raw-table tbody tr").length > 0);
    const rows = await page
      .locator("#raw-table tbody tr")
      .evaluateAll((trs) =>
        trs.map((tr) => [...tr.children].map((td) => td.querySelector("code")?.textContent ?? td.textContent)),
      );
    assert.ok(
      rows.every(([, dir, id, name]) => dir === "received" && id === "1" && name === "position_feedback"),
      JSON.stringify(rows.slice(0, 3)),
    );
    await page.check("#raw-pause");
    const first = await page.textContent("#raw-table tbody tr:first-child");
    await page.waitForFunction(
      (n) => window.dashboard.frames.length > n + 50,
      await page.evaluate(() => window.dashboard.frames.length),
    );
    assert.equal(await page.textContent("#raw-table tbody tr:first-child"), first, "paused display");
    await page.uncheck("#raw-pause");
    await page.selectOption("#raw-message", "");
    await page.selectOption("#raw-dir", "");
    await page.fill("#raw-id", "");
    await page.fill("#raw-search", "set_control");
    await page.uncheck("#raw-polling");
    await page.waitForFunction(() => document.querySelectorAll("#raw-table tbody tr").length > 0);
    const [download] = await Promise.all([page.waitForEvent("download"), page.click("#raw-export")]);
    const log = readFileSync(await download.path(), "utf8");
    assert.ok(log.trim().split("\n").length >= 1);
    const replayed = spawnSync(NURIMC_BIN, ["replay", await download.path()], { encoding: "utf8" });
    assert.equal(replayed.status, 0, replayed.stderr);
    assert.match(replayed.stdout, /set_control/, "nurimc replay decodes the exported log");
    await page.uncheck("#raw-on");
  } finally {
    await page.close();
  }
});

test("the plots follow the window's size", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=motors]");
    const width = () => page.evaluate(() => window.dashboard.motors.get(1).plot.width);
    const wide = await width();
    await page.setViewportSize({ width: 480, height: 900 });
    await page.waitForFunction((w) => window.dashboard.motors.get(1).plot.width < w - 50, wide);
    const box = await page.locator("#motor-1 .plot").boundingBox();
    assert.ok(Math.abs((await width()) - box.width) <= 3, "the plot fills its card");
    await page.setViewportSize({ width: 1400, height: 900 });
    await page.waitForFunction((w) => Math.abs(window.dashboard.motors.get(1).plot.width - w) <= 3, wide);
  } finally {
    await page.close();
  }
});

test("the main plot draws every motor's series while three motors move (pixels counted per series)", async () => {
  const page = await fresh();
  try {
    // all three turning: their samples interleave on the shared time axis
    for (const id of [1, 2, 3])
      await page.evaluate((id) => window.dashboard.link.request("run", { id, rpm: 20 + 10 * id, ramp: 0.1 }), id);
    await page.click("nav button[data-view=plot]");
    await page.waitForFunction(() => window.dashboard.overlay.plot?.data[0].length > 100);
    const colours = ["#2f6fdf", "#e07b00", "#0f9d58"]; // the three position series: a colour per motor (core/plotstyle.js)
    await page.mouse.move(5, 5); // the cursor away from the plot: the legend shows the latest values
    const legend = await page
      .locator("#main-plot .u-legend .u-series")
      .evaluateAll((rows) =>
        rows
          .slice(1)
          .map((row) => [row.querySelector(".u-label").textContent, row.querySelector(".u-value").textContent]),
      );
    assert.deepEqual(
      legend.map(([label]) => label),
      ["ID 1 position", "ID 2 position", "ID 3 position"],
    );
    assert.ok(
      legend.every(([, value]) => /^-?[\d,]+\.\d+$/.test(value)),
      `legend shows latest values: ${JSON.stringify(legend)}`,
    );
    const pixels = await countPixels(page, "#main-plot", colours);
    for (const c of colours) assert.ok(pixels[c] > 400, `every series is drawn as a line: ${JSON.stringify(pixels)}`);
    // the status bar: the bus's frames per second, errors, stale answers and busy waits
    await page.waitForFunction(
      () => (Number.parseInt(document.querySelector("#bar-frames").textContent.replace(/,/g, ""), 10) || 0) > 100,
    );
    for (const [id, pattern] of [
      ["#bar-rate", /^[\d,]+ readings\/s$/],
      ["#bar-errors", /^\d+ errors$/],
      ["#bar-stale", /^\d+ stale answers$/],
      ["#bar-busy", /^\d+ busy waits$/],
    ])
      assert.match(await page.textContent(id), pattern);
    // any signal: speed and current on their own axes
    await page.locator("#plot-signals input[value=speed]").check();
    await page.locator("#plot-signals input[value=current]").check();
    await page.locator("#plot-signals input[value=error]").check();
    await page.waitForFunction(() => window.dashboard.overlay.plot?.series.length === 1 + 3 * 4);
    const axes = await page.evaluate(() =>
      window.dashboard.overlay.plot.axes.slice(1).map((a) => `${a.scale}:${a.label}:${a.side}`),
    );
    assert.deepEqual(axes, ["deg:°:3", "rpm:RPM:1", "amp:A:1"], "one axis per unit, ° on the left");
    // wheel: zoom around the cursor, Shift+wheel: pan; both pause; double-click resumes
    const over = await page.locator("#main-plot .u-over").boundingBox();
    const range = () =>
      page.evaluate(() => [window.dashboard.overlay.plot.scales.x.min, window.dashboard.overlay.plot.scales.x.max]);
    await page.mouse.move(over.x + over.width / 2, over.y + over.height / 2);
    const [min0, max0] = await range();
    await page.mouse.wheel(0, -100);
    await page.waitForFunction(() => document.querySelector("#view-plot").dataset.paused === "yes");
    const [min1, max1] = await range();
    assert.ok(max1 - min1 < (max0 - min0) * 0.9, `zoomed in: ${[min0, max0]} -> ${[min1, max1]}`);
    await page.keyboard.down("Shift");
    await page.mouse.wheel(0, 100);
    await page.keyboard.up("Shift");
    await page.waitForFunction((min1) => window.dashboard.overlay.plot.scales.x.min !== min1, min1);
    const [min2, max2] = await range();
    assert.ok(
      Math.abs(max2 - min2 - (max1 - min1)) < 1e-6 && min2 > min1,
      `panned: ${[min1, max1]} -> ${[min2, max2]}`,
    );
    await page.locator("#main-plot .u-over").dblclick();
    await page.waitForFunction(() => document.querySelector("#view-plot").dataset.paused === "no");
    // pause, export
    await page.click("#plot-pause");
    const frozen = await page.evaluate(() => window.dashboard.overlay.plot.data[0].length);
    await page.waitForFunction(
      (n) => window.dashboard.samplesReceived > n + 50,
      await page.evaluate(() => window.dashboard.samplesReceived),
    );
    assert.equal(await page.evaluate(() => window.dashboard.overlay.plot.data[0].length), frozen, "paused");
    await page.click("#plot-pause");
    const [csv] = await Promise.all([page.waitForEvent("download"), page.click("#plot-csv")]);
    assert.match(
      readFileSync(await csv.path(), "utf8").split("\n")[0],
      /^motor_id,t_s,position_deg,target_deg,following_error_deg/,
    );
    const [png] = await Promise.all([page.waitForEvent("download"), page.click("#plot-png")]);
    assert.deepEqual([...readFileSync(await png.path()).subarray(1, 4)], [0x50, 0x4e, 0x47], "a PNG");
    for (const id of [1, 2, 3]) await page.evaluate((id) => window.dashboard.link.request("hold", { id }), id);
  } finally {
    await page.close();
  }
});

test("a new tab shows the known motors at once, without scanning", async () => {
  const page = await fresh();
  try {
    const other = await browser.newPage();
    watch(other, problems);
    await other.addInitScript(SPY);
    await other.goto(dashboard.url);
    await other.waitForFunction(() => document.querySelectorAll(".card").length === 3, null, { timeout: 60000 });
    assert.ok(!(await other.evaluate(() => window.sentOps.includes("discover"))), "no discovery");
    await other.waitForFunction(() => window.dashboard.motors.get(3)?.series.t.length > 0);
    await other.reload();
    await other.waitForFunction(() => document.querySelectorAll(".card").length === 3, null, { timeout: 60000 });
    assert.ok(!(await other.evaluate(() => window.sentOps.includes("discover"))), "no discovery after a reload");
    await other.close();
  } finally {
    await page.close();
  }
});

test("every malformed websocket message gets an error reply and the connection stays open", async () => {
  const page = await fresh();
  try {
    const result = await page.evaluate(async () => {
      const ws = new WebSocket(`ws://${location.host}/ws`);
      const replies = [];
      ws.onmessage = (event) => {
        const m = JSON.parse(event.data);
        if (m.type === "reply") replies.push(m);
      };
      await new Promise((resolve) => {
        ws.onopen = resolve;
      });
      const bad = [
        new Uint8Array([0, 1, 2, 3]),
        "{not json",
        "[".repeat(5000) + "]".repeat(5000),
        '{"op":"move","id":1,"degrees":"inf","rpm":60}',
        '{"op":"move","id":1,"degrees":1e308,"rpm":60}',
        '{"op":"move","id":1,"degrees":1e400,"rpm":60}',
        '{"op":"move","id":1,"degrees":Infinity,"rpm":60}',
        '{"op":"run","id":1,"rpm":30,"ramp":1e300}',
        '{"op":"move","id":"1","degrees":10,"rpm":60}',
        '{"op":"set","id":1,"name":"ratio","value":"inf"}',
        '{"op":"restore","document":{"format":"nurimc-backup/1","motors":[{"id":1,"settings":{"ratio":"inf"}}]}}',
        '{"op":"move","id":1,"degrees":10,"rpm":-60}',
        "[]",
        '{"op":42}',
      ];
      for (const message of bad) ws.send(message);
      const deadline = Date.now() + 5000;
      while (replies.length < bad.length && Date.now() < deadline) await new Promise((r) => setTimeout(r, 20));
      ws.send(JSON.stringify({ op: "watch", req: "ok", ids: [1, 2, 3] }));
      while (!replies.some((r) => r.req === "ok") && Date.now() < deadline) await new Promise((r) => setTimeout(r, 20));
      const open = ws.readyState === WebSocket.OPEN;
      ws.close();
      return { sent: bad.length, replies, open };
    });
    const errors = result.replies.filter((r) => r.req !== "ok");
    assert.equal(errors.length, result.sent, JSON.stringify(result.replies.map((r) => r.error)));
    assert.ok(
      errors.every((r) => r.ok === false && r.error && !/internal error/.test(r.error)),
      JSON.stringify(errors.map((r) => r.error)),
    );
    assert.ok(
      result.replies.some((r) => r.req === "ok" && r.ok),
      "a good message still works afterwards",
    );
    assert.equal(result.open, true);
  } finally {
    await page.close();
  }
});

test("ID and baud changes are verified; factory reset runs only after its typed confirmation", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=setup]");
    await page.waitForFunction(() => document.querySelector("#bus-port option"));
    assert.equal(await page.inputValue("#bus-port"), "sim://");
    await page.selectOption("#setup-motor", "3");
    await page.fill("#new-id", "2");
    await page.click("#change-id");
    await page.waitForFunction(() => /taken|already answers/.test(document.querySelector("#messages").textContent));
    await page.fill("#new-id", "7");
    await page.click("#change-id");
    await page.waitForFunction(() => window.dashboard.motors.has(7) && !window.dashboard.motors.has(3), null, {
      timeout: 60000,
    });
    await page.selectOption("#setup-motor", "7");
    await page.fill("#new-id", "3");
    await page.click("#change-id");
    await page.waitForFunction(() => window.dashboard.motors.has(3) && !window.dashboard.motors.has(7), null, {
      timeout: 60000,
    });
    await page.selectOption("#setup-motor", "3");
    assert.equal(await page.isDisabled("#factory-reset"), true);
    await page.fill("#reset-confirm", "RESET 2");
    assert.equal(await page.isDisabled("#factory-reset"), true, "the wrong motor's phrase does not unlock it");
    await page.fill("#reset-confirm", "RESET 3");
    assert.equal(await page.isDisabled("#factory-reset"), false);
    await page.click("#factory-reset");
    await page.waitForFunction(() =>
      /ID 3 reset: .*ID 0 at 9600/.test(document.querySelector("#setup-text").textContent),
    );
    assert.equal(await page.evaluate(() => window.dashboard.motors.has(3)), false);
    assert.equal(await page.inputValue("#reset-confirm"), "", "the confirmation is used up");
    // bring it back: find it at 9600 as ID 0, give it its ID and rate again (each verified)
    await page.click("nav button[data-view=motors]");
    await page.selectOption("#discover-rates", "9600");
    await page.click("#discover");
    await page.waitForFunction(() => window.dashboard.motors.get(0)?.info.baudrate === 9600, null, { timeout: 60000 });
    await page.selectOption("#discover-rates", "all");
    await page.click("nav button[data-view=setup]");
    await page.selectOption("#setup-motor", "0");
    await page.fill("#new-id", "3");
    await page.click("#change-id");
    await page.waitForFunction(() => window.dashboard.motors.has(3) && !window.dashboard.motors.has(0), null, {
      timeout: 60000,
    });
    await page.selectOption("#setup-motor", "3");
    await page.selectOption("#new-baud", "57600");
    await page.click("#change-baud");
    await page.waitForFunction(() => window.dashboard.motors.get(3)?.info.baudrate === 57600, null, { timeout: 60000 });
    // the new motor list may come before the reply: wait for the reply's words
    await page.waitForFunction(() =>
      /now answers at 57600 bps \(verified\)/.test(document.querySelector("#setup-text").textContent),
    );
    await page.evaluate(() => window.dashboard.link.request("set", { id: 3, name: "resolution", value: 1024 }));
  } finally {
    await page.close();
  }
});

test("server mode picks the port and rate; the simulated bus explains it cannot change port", async () => {
  const page = await fresh();
  try {
    await page.evaluate(() => {
      document.querySelector("#bus-text").textContent = ""; // filled again by the ports answer to this visit
    });
    await page.click("nav button[data-view=setup]");
    await page.waitForFunction(() => /open: sim:\/\//.test(document.querySelector("#bus-text").textContent));
    assert.deepEqual(await page.locator("#bus-port option").allTextContents(), ["sim://"]);
    assert.equal((await page.locator("#bus-baud option").allTextContents()).length, 18, "all 18 rates offered");
    await page.evaluate(() => {
      const other = document.createElement("option");
      other.value = other.textContent = "/dev/ttyUSB9";
      document.querySelector("#bus-port").append(other);
    });
    await page.selectOption("#bus-port", "/dev/ttyUSB9");
    await page.click("#bus-open");
    await page.waitForFunction(() =>
      /not opened: .*simulated bus .*--port/.test(document.querySelector("#bus-text").textContent),
    );
    await page.selectOption("#bus-port", "sim://");
  } finally {
    await page.close();
  }
});

const VIEWS = ["motors", "plot", "settings", "step", "sequence", "setup", "backup", "raw"];

/** Every view shown with something in it; `each(view)` runs on each (checks, screenshots). */
async function tour(p, each) {
  await p.waitForFunction(() => window.dashboard.busStats && window.dashboard.motors.get(1).series.t.length > 200);
  for (const view of VIEWS) {
    await p.click(`nav button[data-view=${view}]`);
    if (view === "plot") await p.waitForFunction(() => window.dashboard.overlay.plot?.data[0].length > 10);
    if (view === "settings") await p.waitForFunction(() => window.dashboard.settingsShownFor != null);
    if (view === "step") {
      await p.waitForFunction(() => window.dashboard.gainsShownFor != null);
      await p.fill("#step-amplitude", "45");
      await p.fill("#step-duration", "0.5");
      await p.click("#step-run");
      await p.waitForFunction(() => window.dashboard.stepRuns.length > 0, null, { timeout: 60000 });
    }
    if (view === "sequence")
      await p.evaluate(() =>
        window.dashboard.loadSequence({
          format: "nurimc-sequence/1",
          steps: [
            { kind: "move", id: 1, degrees: 30, rpm: 60 },
            { kind: "wait", seconds: 1 },
            { kind: "set", id: 2, name: "position-kp", value: 50 },
          ],
        }),
      );
    if (view === "setup") await p.waitForFunction(() => document.querySelector("#bus-port option"));
    if (view === "raw") {
      await p.check("#raw-on");
      await p.check("#raw-polling");
      await p.waitForFunction(() => document.querySelectorAll("#raw-table tbody tr").length > 5);
      await p.check("#raw-pause");
    }
    await each(view);
    if (view === "raw") {
      await p.uncheck("#raw-pause");
      await p.uncheck("#raw-on");
    }
  }
  await p.click("nav button[data-view=motors]");
}

/** Visible elements that stick out of the 390 px screen, sideways. */
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

test("desktop 1400x900: a screenshot of every view", async () => {
  const page = await fresh({ viewport: { width: 1400, height: 900 } });
  try {
    for (const [id, rpm] of [
      [1, 12],
      [2, -8],
      [3, 5],
    ])
      await page.evaluate(([id, rpm]) => window.dashboard.link.request("run", { id, rpm, ramp: 0.5 }), [id, rpm]);
    await tour(page, (view) => shot(page, `desktop-${view}.png`));
    for (const id of [1, 2, 3]) await page.evaluate((id) => window.dashboard.link.request("hold", { id }), id);
  } finally {
    await page.close();
  }
});

test("phone 390x844: nothing off-screen in any view, 'connected' on one line, E-STOP and Move in reach, 40 px targets", async () => {
  const phone = await fresh({ viewport: { width: 390, height: 844 } });
  try {
    const status = await phone.locator("#status").boundingBox();
    assert.equal(await phone.textContent("#status"), "connected");
    assert.ok(status.height < 30, `"connected" on one line (${status.height} px high)`);
    const move = await phone.locator("#motor-1 button.move").boundingBox();
    assert.ok(
      move.y + move.height <= 844,
      `the first motor's Move is on the first screen (at ${Math.round(move.y)} px)`,
    );
    await tour(phone, async (view) => {
      const width = await phone.evaluate(() => document.documentElement.scrollWidth);
      assert.ok(width <= 390, `${view}: page is ${width} px wide`);
      assert.deepEqual(await offScreen(phone, 390), [], `${view}: elements off-screen`);
      const small = await phone.evaluate(() =>
        [
          ...document.querySelectorAll(
            "button, select, input:not([type=checkbox]):not([type=radio]), label:has(input[type=checkbox])",
          ),
        ]
          .filter((e) => e.offsetParent !== null && !e.closest(".u-legend"))
          .map((e) => [e.id || e.textContent.trim().slice(0, 20) || e.tagName, e.getBoundingClientRect()])
          .filter(([, r]) => r.width > 0 && (r.height < 40 || r.width < 40))
          .map(([name, r]) => `${name} ${Math.round(r.width)}x${Math.round(r.height)}`),
      );
      assert.deepEqual(small, [], `${view}: targets under 40 px`);
      await phone.evaluate(() => window.scrollTo(0, 0));
      await shot(phone, `phone-${view}.png`);
    });
    await phone.mouse.wheel(0, 3000);
    await phone.waitForFunction(() => window.scrollY > 0);
    const estop = await phone.locator("#estop").boundingBox();
    assert.ok(
      estop.y >= 0 && estop.y + estop.height <= 844 && estop.x + estop.width <= 390,
      "E-STOP stays on screen when scrolled",
    );
  } finally {
    await phone.close();
  }
});

test("a sequence runs, is saved and loaded as JSON, and the E-STOP ends it", async () => {
  const page = await fresh();
  try {
    await page.click("nav button[data-view=sequence]");
    await page.evaluate(() =>
      window.dashboard.loadSequence({
        format: "nurimc-sequence/1",
        steps: [
          { kind: "move", id: 1, degrees: 10, rpm: 600 },
          { kind: "wait", seconds: 0.3 },
          { kind: "set", id: 2, name: "position-kp", value: 60 },
        ],
      }),
    );
    await page.click("#seq-run");
    await page.waitForFunction(() => document.querySelector("#seq-status").dataset.state === "done", null, {
      timeout: 60000,
    });
    const [download] = await Promise.all([page.waitForEvent("download"), page.click("#seq-save")]);
    const saved = JSON.parse(readFileSync(await download.path(), "utf8"));
    assert.deepEqual(
      saved.steps.map((s) => s.kind),
      ["move", "wait", "set"],
    );
    await page.setInputFiles("#seq-load", {
      name: "seq.json",
      mimeType: "application/json",
      buffer: Buffer.from(
        JSON.stringify({
          format: "nurimc-sequence/1",
          steps: [
            { kind: "wait", seconds: 5 },
            { kind: "move", id: 1, degrees: -200, rpm: 600 },
          ],
        }),
      ),
    });
    await page.waitForFunction(() => document.querySelectorAll("#seq-list li").length === 2);
    const moves = await page.evaluate(() => window.sentOps.filter((op) => op === "move").length);
    await page.click("#seq-run");
    await page.waitForFunction(() => document.querySelector("#seq-status").dataset.state === "running");
    await page.click("#estop");
    await page.waitForFunction(() => document.querySelector("#seq-status").dataset.state === "stopped", null, {
      timeout: 60000,
    });
    await afterSamples(page, 60);
    assert.equal(
      await page.evaluate(() => window.sentOps.filter((op) => op === "move").length),
      moves,
      "the move after the wait never went out",
    );
  } finally {
    await page.close();
  }
});

for (const [what, count] of [
  ["holds", 500],
  ["moves", 300],
]) {
  test(`Escape behind ${count} queued ${what} leaves every motor with control off`, async () => {
    const page = await fresh();
    try {
      await page.click("nav button[data-view=motors]");
      await page.evaluate(
        ([what, count]) => {
          for (let n = 0; n < count; n++) {
            const id = 1 + (n % 3);
            const request =
              what === "holds"
                ? window.dashboard.link.request("hold", { id })
                : window.dashboard.link.request("move", { id, degrees: (n % 40) * 10 - 200, rpm: 300 });
            request.catch(() => {});
          }
        },
        [what, count],
      );
      await page.evaluate(() => {
        delete document.querySelector("#estop").dataset.lastResult;
      });
      const generation = await page.evaluate(() => window.dashboard.link.generation);
      await page.locator("#motor-2 .controls input").first().focus(); // Escape works from inside a field too
      await page.keyboard.press("Escape");
      await page.waitForFunction(
        () => (document.querySelector("#estop").dataset.lastResult ?? "").startsWith("{"),
        null,
        { timeout: 60000 },
      );
      // anything from before the stop would have run by now (about 300 ms of samples later)
      await page.waitForFunction(
        (n) => window.dashboard.samplesReceived > n + 100,
        await page.evaluate(() => window.dashboard.samplesReceived),
      );
      assert.deepEqual(
        await controls(page),
        { 1: "off", 2: "off", 3: "off" },
        await page.getAttribute("#estop", "data-last-result"),
      );
      const shown = await page.evaluate(() =>
        [...document.querySelectorAll(".card")].map((card) => card.dataset.control),
      );
      assert.deepEqual(shown, ["off", "off", "off"], await page.getAttribute("#estop", "data-last-result"));
      assert.equal(await page.getAttribute("#estop", "data-rates"), "57600,115200", "sent at every known rate");
      assert.ok((await page.evaluate(() => window.dashboard.link.generation)) > generation, "a new generation");
      const stale = await page.evaluate(
        (gen) =>
          new Promise((resolve) => {
            const ws = window.dashboard.link.ws;
            const listener = (event) => {
              const m = JSON.parse(event.data);
              if (m.req !== "stale") return;
              ws.removeEventListener("message", listener);
              resolve(m);
            };
            ws.addEventListener("message", listener);
            ws.send(JSON.stringify({ op: "hold", req: "stale", id: 1, gen }));
          }),
        generation,
      );
      assert.match(stale.error, /before emergency stop/, "a command from before the stop is refused");
      // the state stays: every card says "stopped" and the banner stays up until a new command
      const states = () => page.evaluate(() => [...document.querySelectorAll(".card")].map((c) => c.dataset.state));
      await page.waitForFunction(
        (n) => window.dashboard.samplesReceived > n + 200,
        await page.evaluate(() => window.dashboard.samplesReceived),
      );
      assert.deepEqual(await states(), ["stopped", "stopped", "stopped"]);
      assert.ok(await page.isVisible("#stop-banner"), "the stop banner stays");
      assert.match(await page.textContent("#stop-banner"), /STOPPED by the emergency stop/);
      await page.locator("#motor-1").getByRole("button", { name: "Hold" }).click();
      await page.waitForSelector("#stop-banner.hidden", { state: "attached" });
      await page.waitForFunction(() => document.querySelector("#motor-1").dataset.state !== "stopped");
      assert.deepEqual((await states()).slice(1), ["stopped", "stopped"], "the others keep their stopped state");
    } finally {
      await page.close();
    }
  });
}

test("the browser console stayed clean: no errors, no failed loads (favicon included)", () => {
  assert.deepEqual(problems, []);
});

function handshake(url, headers) {
  const { host, port } = new URL(url);
  return new Promise((resolve, reject) => {
    const req = httpRequest({
      host: "127.0.0.1",
      port,
      path: "/ws",
      headers: {
        Connection: "Upgrade",
        Upgrade: "websocket",
        "Sec-WebSocket-Version": "13",
        "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
        Host: host,
        ...headers,
      },
    });
    req.on("upgrade", (response, socket) => {
      socket.destroy();
      resolve(response.statusCode);
    });
    req.on("response", (response) => {
      response.resume();
      resolve(response.statusCode);
    });
    req.on("error", reject);
    req.end();
  });
}

test("a cross-origin websocket is refused; the console's own origin is accepted", async () => {
  const own = new URL(dashboard.url);
  assert.equal(await handshake(dashboard.url, { Origin: `http://${own.host}` }), 101);
  assert.equal(await handshake(dashboard.url, { Origin: "http://evil.example" }), 403);
  assert.equal(await handshake(dashboard.url, {}), 403, "no Origin");
  assert.equal(
    await handshake(dashboard.url, { Origin: "http://evil.example", Host: "evil.example" }),
    403,
    "rebinding Host",
  );
});

test("server hung: the E-STOP is not confirmed within 1 s and says so in red; the page notices the silence", async () => {
  await page.click("nav button[data-view=motors]");
  dashboard.child.kill("SIGSTOP");
  try {
    await page.keyboard.press("Escape");
    // "no receipt" comes from the 1 s receipt timer; the 3 s silence watchdog would have made it "failed"
    await page.waitForFunction(() => document.querySelector("#estop").dataset.lastResult === "no receipt", null, {
      timeout: 60000,
    });
    assert.match(await page.textContent("#banner-text"), /E-STOP NOT CONFIRMED/);
    assert.equal(await page.isVisible("#banner"), true);
    assert.equal(
      await page.evaluate(() => getComputedStyle(document.querySelector("#banner")).backgroundColor),
      "rgb(192, 38, 45)",
      "red",
    );
    await page.waitForFunction(() => !window.dashboard.connected, null, { timeout: 60000 });
    assert.match(await page.textContent("#banner-detail"), /no word from the server/);
    assert.equal(await page.evaluate(() => document.querySelector("#controls").disabled), true, "controls disabled");
  } finally {
    dashboard.child.kill("SIGCONT");
  }
  await page.waitForFunction(() => window.dashboard.connected, null, { timeout: 60000 });
  await page.waitForSelector("#banner.hidden", { state: "attached" });
});

test("server killed: banner, controls off, E-STOP says unreachable at once; restarted: reconnects, motors back", async () => {
  const port = new URL(dashboard.url).port;
  const lastBefore = await page.evaluate(() => window.dashboard.motors.get(1).series.t.at(-1));
  await page.evaluate(() => {
    window.dashboard.retryDelays = [];
  });
  const exited = new Promise((resolve) => dashboard.child.once("exit", resolve));
  dashboard.stop();
  await exited;
  await page.waitForSelector("#banner:not(.hidden)", { timeout: 60000 });
  assert.match(await page.textContent("#banner"), /unreachable/i);
  assert.equal(await page.evaluate(() => document.querySelector("#controls").disabled), true, "controls disabled");
  assert.equal(await page.locator("#motor-1").getByRole("button", { name: "Move" }).isDisabled(), true);
  const said = await page.evaluate(() => {
    document.querySelector("#estop").click();
    return document.querySelector("#banner").textContent;
  });
  assert.match(said, /E-STOP NOT SENT/, "said at once, in the same click");
  assert.equal(await page.getAttribute("#estop", "data-last-result"), "unreachable");
  assert.equal(
    await page.evaluate(() => getComputedStyle(document.querySelector("#banner")).backgroundColor),
    "rgb(192, 38, 45)",
    "red",
  );
  await page.screenshot({ path: join(SHOTS, "disconnected.png") });
  await page.waitForFunction(() => window.dashboard.retryDelays.length >= 4, null, { timeout: 60000 });
  const delays = await page.evaluate(() => window.dashboard.retryDelays);
  assert.deepEqual(delays.slice(0, 4), [250, 500, 1000, 2000], "reconnects with backoff");
  dashboard = await startDashboard(["--listen", `127.0.0.1:${port}`]);
  await page.waitForSelector("#banner.hidden", { state: "attached", timeout: 60000 });
  await page.waitForFunction(() => window.dashboard.connected && window.dashboard.motors.size === 3, null, {
    timeout: 60000,
  });
  await page.waitForFunction(() => document.querySelector("#discover-text").dataset.found === "1,2,3", null, {
    timeout: 60000,
  });
  const t = await page.evaluate(() => window.dashboard.samplesReceived);
  await page.waitForFunction((t) => window.dashboard.samplesReceived > t + 10, t, { timeout: 60000 });
  assert.equal(await page.evaluate(() => document.querySelector("#controls").disabled), false, "controls back");
  await afterSamples(page, 30);
  const plot = await page.evaluate(() => {
    const motor = window.dashboard.motors.get(1);
    return { t: motor.series.t, x: motor.plot.data[0] };
  });
  assert.ok(plot.t[0] <= lastBefore && plot.t.at(-1) > lastBefore, "the plot kept what it had and carries on");
  assert.ok(
    plot.t.every((v, i) => i === 0 || v > plot.t[i - 1]),
    "time only moves forward across the restart",
  );
  assert.ok(plot.x.at(-1) === 0 && plot.x.every((v, i) => i === 0 || v > plot.x[i - 1]), "the plot ends at now");
});

test("direct mode (Web Serial bridged to the simulator): an E-STOP behind 300 queued moves turns every motor off, confirmed", async () => {
  const bundle = join(ROOT, "ts/dist/nurimc.browser.js");
  assert.ok(existsSync(bundle), "ts/dist/nurimc.browser.js is built by `make -f ts/Makefile.inc ts-build`");
  const link = join(mkdtempSync(join(tmpdir(), "nurimc-direct-")), "bus");
  const [site, sim] = await Promise.all([
    startStaticSite(bundle),
    startPtySimulator(link, ["--ids", "1,2,3", "--baud", "115200"]),
  ]);
  const direct = await browser.newPage();
  direct.setDefaultTimeout(60000);
  watch(direct, problems);
  const bridge = await startBridge(direct, link);
  try {
    await direct.goto(site.url);
    await direct.waitForFunction(
      () => window.dashboard.mode === "direct" && !document.querySelector("#connect").disabled,
    );
    assert.match(await direct.textContent("#mode"), /direct/);
    await direct.selectOption("#direct-baud", "115200");
    await direct.click("#connect");
    await direct.waitForFunction(() => document.querySelectorAll(".card").length === 3, null, { timeout: 30000 });
    assert.deepEqual(await direct.evaluate(() => window.__serialOpened.baudRate), 115200);
    await direct.waitForFunction(
      () => /found 3 motor/.test(document.querySelector("#discover-text").textContent),
      null,
      { timeout: 30000 },
    );
    await direct.waitForFunction(() => [1, 2, 3].every((id) => window.dashboard.motors.get(id)?.series.t.length > 5));
    await shot(direct, "direct-mode.png");
    // 300 moves queued in the TS client, then the stop
    const result = await direct.evaluate(async () => {
      const moves = [];
      for (let n = 0; n < 300; n++) {
        const id = 1 + (n % 3);
        moves.push(
          window.dashboard.link.request("move", { id, degrees: (n % 40) * 10 - 200, rpm: 300 }).then(
            () => "sent",
            (e) => e.name,
          ),
        );
      }
      document.querySelector("#estop").click();
      const outcomes = await Promise.all(moves);
      return {
        cancelled: outcomes.filter((o) => o === "CancelledError").length,
        sent: outcomes.filter((o) => o === "sent").length,
      };
    });
    await direct.waitForFunction(
      () => (document.querySelector("#estop").dataset.lastResult ?? "").startsWith("{"),
      null,
      { timeout: 60000 },
    );
    assert.deepEqual(
      JSON.parse(await direct.getAttribute("#estop", "data-last-result")),
      { 1: "off", 2: "off", 3: "off" },
      "confirmed by read-back",
    );
    assert.ok(result.cancelled >= 297, `the queued moves were cancelled, not sent: ${JSON.stringify(result)}`);
    // read back again from the bus after the queue had every chance to run: still off
    await direct.waitForFunction(
      (n) => window.dashboard.samplesReceived > n + 60,
      await direct.evaluate(() => window.dashboard.samplesReceived),
    );
    const control = await direct.evaluate(async () => {
      const out = {};
      for (const id of [1, 2, 3])
        out[id] = (await window.dashboard.link.request("read_settings", { id })).settings.control;
      return out;
    });
    assert.deepEqual(control, { 1: "off", 2: "off", 3: "off" });
    assert.deepEqual(await direct.evaluate(() => [...document.querySelectorAll(".card")].map((c) => c.dataset.state)), [
      "stopped",
      "stopped",
      "stopped",
    ]);
    assert.ok(await direct.isVisible("#stop-banner"));
  } finally {
    await direct.close();
    await bridge.close();
    sim.stop();
    site.stop();
  }
});

/** Visible English left on a page shown in Korean: words of 2+ Latin letters outside code, units, IDs and names. */
const ALLOWED =
  /\b(ID|RPM|bps|ms|µs|s|A|B|Kp|Ki|Kd|CSV|PNG|JSON|EEPROM|Web Serial|Esc|RESET|nurimc|dashboard|MC|BLMC-H|sim|Chrome|Edge|https?|localhost|USB|TCP|CCW|CW)\b/g;
const englishLeft = (p) =>
  p.evaluate((allowed) => {
    const pattern = new RegExp(allowed, "g");
    const out = new Set();
    const visible = (e) =>
      e && !e.closest(".hidden, code, kbd, script, style, .u-axis") && e.getClientRects().length > 0;
    const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
    const texts = [];
    for (let node = walker.nextNode(); node; node = walker.nextNode())
      if (visible(node.parentElement)) texts.push(node.textContent);
    for (const e of document.querySelectorAll("input[placeholder]")) if (visible(e)) texts.push(e.placeholder);
    for (const e of document.querySelectorAll("select"))
      if (visible(e)) for (const option of e.options) texts.push(option.textContent); // every choice, open or not
    for (const text of texts) {
      const left = text.replace(pattern, " ").replace(/[a-z_]+(?:[_-][a-z]+)+/g, " "); // message and setting names are code
      for (const word of left.match(/[A-Za-z]{2,}/g) ?? []) out.add(`${word} (in "${text.trim().slice(0, 60)}")`);
    }
    return [...out];
  }, ALLOWED.source);

test("Korean: a Korean browser gets every view in Korean (vendor terms), the switch goes to English and back, and is remembered", async () => {
  const korean = await launchBrowser({ locale: "ko-KR", viewport: { width: 1400, height: 900 } });
  try {
    const page = await openConsole(korean, dashboard.url);
    watch(page, problems);
    assert.equal(await page.evaluate(() => document.documentElement.lang), "ko");
    assert.equal(await page.textContent("#status"), "연결됨");
    await tour(page, async (view) => {
      assert.deepEqual(await englishLeft(page), [], `${view}: English left on the Korean page`);
      if (view === "settings") {
        const names = await page.locator("#settings-table td.name span").allTextContents();
        for (const term of [
          "위치제어기 Kp",
          "속도제어기 Kp",
          "위치제어 정격전류",
          "감속비",
          "분해능",
          "통신 응답시간",
          "모터 정격속도",
        ])
          assert.ok(names.includes(term), `the vendor's term ${term} in ${names}`);
      }
      await shot(page, `ko-${view}.png`);
    });
    // the emergency stop: badges and the banner in Korean too
    await page.keyboard.press("Escape");
    await page.waitForSelector("#stop-banner:not(.hidden)");
    await page.waitForFunction(() =>
      [...document.querySelectorAll(".card")].every((c) => c.dataset.state === "stopped"),
    );
    assert.match(await page.textContent("#stop-banner"), /비상 정지로 정지됨/);
    assert.match(await page.textContent("#motor-1 .state"), /정지됨/);
    assert.deepEqual(await englishLeft(page), [], "E-STOP: English left");
    await shot(page, "ko-estop.png");
    // numbers and messages follow the language; an English server error is shown in Korean
    await page.locator("#motor-1 input.to").fill("700");
    await page.locator("#motor-1 button.move").click();
    assert.match(await page.locator("#messages .message:last-child .text").textContent(), /장치 범위/);
    const refused = await page.evaluate(() =>
      window.dashboard.link.request("move", { id: 1, degrees: 700, rpm: 60 }).catch((e) => e.message),
    );
    assert.match(refused, /655\.33/, "the server speaks English");
    await page.click("nav button[data-view=setup]");
    await page.selectOption("#setup-motor", "3");
    await page.fill("#new-id", "2");
    await page.click("#change-id");
    await page.waitForFunction(() => /이미 버스에서 응답/.test(document.querySelector("#messages").textContent));
    assert.deepEqual(
      await englishLeft(page),
      [],
      "the server's English error is said in Korean (the original kept in a code span)",
    );
    await page.click("nav button[data-view=motors]");
    // switch to English and back
    await page.selectOption("#lang", "en");
    await page.waitForFunction(() => document.querySelector("#status").textContent === "connected");
    assert.equal(await page.textContent("nav button[data-view=settings]"), "Settings");
    assert.equal(await page.evaluate(() => document.documentElement.lang), "en");
    await page.selectOption("#lang", "ko");
    await page.waitForFunction(() => document.querySelector("#status").textContent === "연결됨");
    await page.selectOption("#lang", "en");
    await page.reload();
    await page.waitForFunction(() => window.dashboard?.connected);
    assert.equal(
      await page.textContent("nav button[data-view=motors]"),
      "Motors",
      "the choice is remembered over the browser's language",
    );
    await page.selectOption("#lang", "ko");
    await page.close();
  } finally {
    await korean.close();
  }
});

test("the uPlot copied from npm next to the page is the version e2e/package.json pins", () => {
  const pinned = JSON.parse(readFileSync(join(ROOT, "e2e/node_modules/uplot/package.json"))).version;
  assert.equal(readFileSync(join(STATIC, "vendor/uplot/VERSION"), "utf8").trim(), pinned);
  assert.deepEqual(
    readFileSync(join(STATIC, "vendor/uplot/uPlot.esm.js")),
    readFileSync(join(ROOT, "e2e/node_modules/uplot/dist/uPlot.esm.js")),
  );
});
