// Live plot rate: samples of one motor that reach the page per second, counted in the browser
// while the motor moves. Writes benchmarks/results/dashboard-rate.json. Not a test: it records.
import { writeFileSync, mkdirSync } from "node:fs";
import { join } from "node:path";
import { cpus } from "node:os";
import { ROOT, startDashboard, launchBrowser, discover } from "./lib.mjs";

const SECONDS = Number(process.env.SECONDS_MEASURED ?? 10);
const dashboard = await startDashboard();
const browser = await launchBrowser();
try {
  const page = await browser.newPage();
  await page.goto(dashboard.url);
  await discover(page);
  await page.evaluate(() => window.dashboard.link.request("watch", { ids: [1] }));
  await page.evaluate(() => window.dashboard.link.request("run", { id: 1, rpm: 30, ramp: 0.5 }));
  await page.waitForTimeout(1000);
  const measure = () => page.evaluate(() => {
    const s = window.dashboard.motors.get(1).series;
    return { received: window.dashboard.samplesReceived, now: performance.now(), redrawn: s.t.at(-1) };
  });
  const first = await measure();
  await page.waitForTimeout(SECONDS * 1000);
  const last = await measure();
  const elapsed = (last.now - first.now) / 1000;
  const result = {
    benchmark: "dashboard live plot rate, one motor (nurimc dashboard --sim, headless Chromium)",
    bus: "simulated, wire timing on, 115200 bps, in-process",
    seconds: Number(elapsed.toFixed(2)),
    samples: last.received - first.received,
    updates_per_second: Number(((last.received - first.received) / elapsed).toFixed(1)),
    goal_per_second: 50,
    machine: `${cpus().length} cores, ${cpus()[0]?.model ?? "?"}`,
    date: new Date().toISOString(),
  };
  mkdirSync(join(ROOT, "benchmarks/results"), { recursive: true });
  writeFileSync(join(ROOT, "benchmarks/results/dashboard-rate.json"), JSON.stringify(result, null, 2) + "\n");
  console.log(JSON.stringify(result, null, 2));
  await page.evaluate(() => window.dashboard.link.request("release", { id: 1 }));
} finally {
  await browser.close();
  dashboard.stop();
}
