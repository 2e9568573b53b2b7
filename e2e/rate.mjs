// Live-update rate of the console for one motor, as the page receives it (goal: >= 50 per second).
// Records benchmarks/results/dashboard-rate.json. Run: make -f e2e/Makefile.inc e2e-rate
import { writeFileSync } from "node:fs";
import { loadavg } from "node:os";
import { join } from "node:path";
import { discover, launchBrowser, ROOT, startDashboard } from "./lib.mjs";

const SECONDS = 5;
const [dashboard, browser] = await Promise.all([startDashboard(), launchBrowser()]);
try {
  const page = await browser.newPage();
  await page.goto(dashboard.url);
  const ids = await discover(page);
  await page.waitForTimeout(1000); // let the watch loop settle
  // samplesReceived: every (motor, time) sample the page has taken into its plots
  const count = () => page.evaluate(() => ({ total: window.dashboard.samplesReceived }));
  const start = await count();
  const t0 = Date.now();
  await page.waitForTimeout(SECONDS * 1000);
  const end = await count();
  const elapsed = (Date.now() - t0) / 1000;
  const total = (end.total - start.total) / elapsed;
  const result = {
    motors_watched: ids.length,
    samples_per_second_all_motors: Math.round(total * 10) / 10,
    samples_per_second_per_motor: Math.round((total / ids.length) * 10) / 10,
    goal_per_motor: 50,
    seconds: elapsed,
    transport: "nurimc dashboard --sim (wire timing on, motors at 115200 and 57600 bps), headless Chromium",
    host_load_1min: Math.round(loadavg()[0] * 10) / 10, // a shared 2-core machine: figures drop with its load
    date: new Date().toISOString().slice(0, 10),
  };
  console.log(JSON.stringify(result, null, 2));
  writeFileSync(join(ROOT, "benchmarks/results/dashboard-rate.json"), JSON.stringify(result, null, 2) + "\n");
} finally {
  await browser.close();
  dashboard.stop();
}
