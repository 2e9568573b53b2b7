// The console's Auto-tune panel (issue 35) in headless Chromium against `nurimc dashboard --sim`:
// a tune runs with each trial drawn as a run, ends with the starting gains back, Apply writes the
// chosen gains (read back); Cancel mid-tune writes the starting gains back.
import assert from "node:assert/strict";
import { mkdirSync, mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { after, before, test } from "node:test";
import { discover, launchBrowser, ROOT, startDashboard } from "./lib.mjs";

const SHOTS = process.env.NURIMC_SCREENSHOTS
  ? join(ROOT, "docs/screenshots")
  : mkdtempSync(join(tmpdir(), "nurimc-shots-"));
let dashboard, browser, page;
const problems = [];

before(async () => {
  mkdirSync(SHOTS, { recursive: true });
  [dashboard, browser] = await Promise.all([startDashboard(), launchBrowser()]);
  page = await browser.newPage();
  page.setDefaultTimeout(20000);
  page.on("pageerror", (error) => problems.push(`page error: ${error.message}`));
  page.on("console", (m) => {
    if (m.type() === "error") problems.push(`console: ${m.text()}`);
  });
  await page.goto(dashboard.url);
  await discover(page);
});

after(async () => {
  await browser?.close();
  dashboard?.stop();
});

const gainsOf = (id) =>
  page.evaluate(async (id) => {
    const s = (await window.dashboard.link.request("read_settings", { id })).settings;
    return { kp: s["position-kp"], ki: s["position-ki"], kd: s["position-kd"] };
  }, id);

test("auto-tune draws each trial as a run, ends with the starting gains back, and Apply writes the chosen gains", async () => {
  await page.click("nav button[data-view=step]");
  await page.selectOption("#step-motor", "1");
  const starting = await gainsOf(1);
  await page.selectOption("#tune-goal", "no-overshoot");
  await page.fill("#tune-travel", "30");
  await page.fill("#tune-trials", "4");
  await page.click("#tune-run");
  await page.waitForFunction(() => document.querySelector("#tune-panel").dataset.state === "running");
  // a trial is a row of the runs table (and a line of the plot) while the tune still runs
  await page.waitForFunction(() => window.dashboard.stepRuns.some((run) => run.tune), null, { timeout: 120000 });
  const whileRunning = await page.evaluate(() => ({
    state: document.querySelector("#tune-panel").dataset.state,
    rows: document.querySelectorAll("#step-runs tbody tr").length,
    points: Number(document.querySelector("#step-plot").dataset.points),
  }));
  assert.ok(whileRunning.rows >= 1 && whileRunning.points > 5, JSON.stringify(whileRunning));
  await page.waitForFunction(
    () => ["done", "failed"].includes(document.querySelector("#tune-panel").dataset.state),
    null,
    {
      timeout: 180000,
    },
  );
  const result = await page.evaluate(() => window.dashboard.tuneResult);
  assert.equal(await page.getAttribute("#tune-panel", "data-state"), "done", JSON.stringify(problems));
  assert.equal(result.trials.length, 4);
  assert.deepEqual(result.start_gains, starting);
  assert.deepEqual(await gainsOf(1), starting, "the starting gains are back until Apply");
  assert.equal(await page.locator("#step-runs tbody tr").count(), 4, "each trial is a row");
  assert.match(await page.textContent("#tune-result"), /starting .* → chosen/);
  await page.screenshot({ path: join(SHOTS, "tune.png"), fullPage: true });
  assert.notDeepEqual(result.chosen_gains, starting, "the tune found better gains");
  assert.equal(await page.isDisabled("#tune-apply"), false);
  await page.click("#tune-apply");
  await page.waitForFunction(() => document.querySelector("#tune-panel").dataset.state === "applied");
  assert.deepEqual(await gainsOf(1), result.chosen_gains, "applied, read back");
  assert.equal(await page.inputValue("#gain-kp"), String(result.chosen_gains.kp));
  assert.deepEqual(problems, []);
});

test("Cancel mid-tune writes the starting gains back", async () => {
  const starting = await gainsOf(1);
  await page.fill("#tune-trials", "20");
  await page.click("#tune-run");
  await page.waitForFunction(() => window.dashboard.tuneTrials.length >= 1, null, { timeout: 120000 });
  await page.click("#tune-cancel");
  await page.waitForFunction(() => document.querySelector("#tune-panel").dataset.state === "cancelled", null, {
    timeout: 60000,
  });
  const result = await page.evaluate(() => window.dashboard.tuneResult);
  assert.equal(result.cancelled, true);
  assert.equal(result.restored, true);
  assert.ok(result.trials.length < 20);
  assert.deepEqual(await gainsOf(1), starting, "the starting gains, read back");
  assert.match(await page.textContent("#tune-text"), /cancelled: the starting gains .* were written back/);
  assert.deepEqual(problems, []);
});
