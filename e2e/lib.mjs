// Shared by the end-to-end tests and the rate benchmark: the server, the browser, a static site.
import { spawn } from "node:child_process";
import { existsSync, mkdtempSync, readFileSync } from "node:fs";
import { createServer } from "node:http";
import { tmpdir } from "node:os";
import { dirname, extname, join, normalize } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

export const ROOT = join(dirname(fileURLToPath(import.meta.url)), "..");
export const STATIC = join(ROOT, "python/src/nurimc/dashboard/static");
const NURIMC = process.env.NURIMC_BIN ?? join(ROOT, ".venv/bin/nurimc");
const CHROMIUM = process.env.CHROMIUM_BIN ?? "/usr/bin/chromium";

/** `nurimc dashboard --sim` on a free port; resolves with its URL once it prints `ready:`. */
export function startDashboard(extra = []) {
  return serveDashboard(["dashboard", "--sim", "--listen", "127.0.0.1:0", ...extra]);
}

/** `nurimc --port PORT --baud RATE dashboard` (a real port, reopened by itself when lost) on a free port. */
export function startPortDashboard(port, baud = 115200) {
  return serveDashboard(["--port", port, "--baud", String(baud), "dashboard", "--listen", "127.0.0.1:0"]);
}

function serveDashboard(args) {
  const child = spawn(NURIMC, args, {
    stdio: ["ignore", "pipe", "pipe"],
  });
  let output = "";
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`dashboard did not start in 60 s:\n${output}`)), 60000);
    const look = (chunk) => {
      output += chunk;
      const match = /ready: (http:\/\/\S+)/.exec(output);
      if (match) {
        clearTimeout(timer);
        resolve({ url: match[1], child, stop: () => child.kill("SIGTERM") });
      }
    };
    child.stdout.on("data", look);
    child.stderr.on("data", (chunk) => {
      output += chunk;
    });
    child.on("exit", (code) => {
      clearTimeout(timer);
      reject(new Error(`dashboard exited with ${code}:\n${output}`));
    });
  });
}

export async function launchBrowser({ locale = "en-US", viewport = { width: 1400, height: 900 } } = {}) {
  if (!existsSync(CHROMIUM))
    throw new Error(`${CHROMIUM} is missing: run \`make system-deps\` (Debian package chromium)`);
  const profile = mkdtempSync(join(tmpdir(), "nurimc-e2e-"));
  return chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport,
    locale, // navigator.languages and Accept-Language: the page picks its language from them
    args: [
      "--headless",
      "--no-sandbox",
      "--disable-gpu",
      "--disable-background-networking",
      "--disable-component-update",
      "--disable-sync",
      "--no-first-run",
      `--lang=${locale}`,
    ],
  });
}

const TYPES = { ".html": "text/html", ".js": "text/javascript", ".css": "text/css", ".map": "application/json" };

/** The page without its server (direct mode): the static files plus the TypeScript bundle. */
export function startStaticSite(bundle) {
  const server = createServer((request, response) => {
    const path =
      normalize(decodeURIComponent(new URL(request.url, "http://x").pathname)).replace(/^\/+/, "") || "index.html";
    const file = path === "nurimc.browser.js" ? bundle : join(STATIC, path);
    if (path.includes("..") || !existsSync(file)) {
      response.writeHead(404).end("not found");
      return;
    }
    response
      .writeHead(200, { "content-type": TYPES[extname(file)] ?? "application/octet-stream" })
      .end(readFileSync(file));
  });
  return new Promise((resolve) =>
    server.listen(0, "127.0.0.1", () =>
      resolve({ url: `http://127.0.0.1:${server.address().port}/`, stop: () => server.close() }),
    ),
  );
}

/** The page discovers on its first load when the server knows no motors; resolves with the IDs it shows. */
export async function discover(page) {
  await page.waitForFunction(() => document.querySelector("#discover-text").dataset.found, null, { timeout: 60000 });
  return (await page.getAttribute("#discover-text", "data-found")).split(",").map(Number);
}

/** `nurimc sim --tcp 0` with controllers at these IDs; resolves with its TCP port once it prints it. */
export function startSimulator(ids = "1,2,3", baud = 115200) {
  const child = spawn(NURIMC, ["sim", "--ids", ids, "--baud", String(baud), "--tcp", "0"], {
    stdio: ["ignore", "pipe", "pipe"],
  });
  let output = "";
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`simulator did not start in 30 s:\n${output}`)), 30000);
    const look = (chunk) => {
      output += chunk;
      const match = /tcp 127\.0\.0\.1:(\d+)/.exec(output);
      if (match) {
        clearTimeout(timer);
        resolve({ port: Number(match[1]), child, stop: () => child.kill("SIGTERM") });
      }
    };
    child.stdout.on("data", look);
    child.stderr.on("data", look);
    child.on("exit", (code) => {
      clearTimeout(timer);
      reject(new Error(`simulator exited with ${code}:\n${output}`));
    });
  });
}

/** The command-line tool, for checks from outside (e.g. `nurimc replay` on an exported log). */
export const NURIMC_BIN = NURIMC;

/** Wait until every motor card shows (a page opened on a server that knows its motors). */
export async function openConsole(browser, url, { viewport, init } = {}) {
  const page = await browser.newPage();
  page.setDefaultTimeout(60000);
  if (viewport) await page.setViewportSize(viewport);
  if (init) await page.addInitScript(init);
  await page.goto(url);
  await page.waitForFunction(
    () =>
      window.dashboard?.connected &&
      document.querySelectorAll(".card").length === 3 &&
      [...window.dashboard.motors.values()].every((m) => m.series.t.length > 2),
    null,
    {
      timeout: 60000,
    },
  );
  return page;
}

/**
 * Pixels of each colour drawn on a plot's canvas: { "#2457c5": n, ... } for the given series
 * colours (a pixel counts if each channel is within `tolerance` of the colour and it is opaque).
 */
export function countPixels(page, selector, colours, tolerance = 40) {
  return page.evaluate(
    ({ selector, colours, tolerance }) => {
      const canvas = document.querySelector(`${selector} canvas`);
      const { width, height } = canvas;
      const data = canvas.getContext("2d").getImageData(0, 0, width, height).data;
      const rgb = colours.map((c) => [1, 3, 5].map((i) => Number.parseInt(c.slice(i, i + 2), 16)));
      const counts = colours.map(() => 0);
      for (let i = 0; i < data.length; i += 4) {
        if (data[i + 3] < 200) continue;
        rgb.forEach(([r, g, b], k) => {
          if (
            Math.abs(data[i] - r) <= tolerance &&
            Math.abs(data[i + 1] - g) <= tolerance &&
            Math.abs(data[i + 2] - b) <= tolerance
          )
            counts[k] += 1;
        });
      }
      return Object.fromEntries(colours.map((c, k) => [c, counts[k]]));
    },
    { selector, colours, tolerance },
  );
}

/**
 * The adapter that drops out: `python -m nurimc.sim.faultproxy` serving a pty (a symlink at
 * `link`) in front of a simulator's TCP port. cut() and restore() signal it (SIGUSR1, SIGUSR2)
 * and resolve once it has printed that it did so.
 */
export function startFaultProxy(upstreamPort, link) {
  const python = join(dirname(NURIMC), "python");
  const child = spawn(
    python,
    ["-m", "nurimc.sim.faultproxy", "--upstream", `127.0.0.1:${upstreamPort}`, "--link", link],
    {
      stdio: ["ignore", "pipe", "pipe"],
    },
  );
  let output = "";
  const waiters = [];
  const said = (word) =>
    new Promise((resolve, reject) => {
      const count = output.split("\n").filter((line) => line.split(" ")[1] === word).length;
      waiters.push({ word, count, resolve, reject });
    });
  const check = () => {
    for (const w of [...waiters]) {
      if (output.split("\n").filter((line) => line.split(" ")[1] === w.word).length > w.count) {
        waiters.splice(waiters.indexOf(w), 1);
        w.resolve();
      }
    }
  };
  const proxy = {
    link,
    child,
    cut: () => {
      const done = said("cut");
      child.kill("SIGUSR1");
      return done;
    },
    restore: () => {
      const done = said("restored");
      child.kill("SIGUSR2");
      return done;
    },
    stop: () => child.kill("SIGTERM"),
  };
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`faultproxy did not start in 30 s:\n${output}`)), 30000);
    child.stdout.on("data", (chunk) => {
      output += chunk;
      if (/ ready /.test(output)) {
        clearTimeout(timer);
        resolve(proxy);
      }
      check();
    });
    child.stderr.on("data", (chunk) => {
      output += chunk;
    });
    child.on("exit", (code) => {
      clearTimeout(timer);
      for (const w of waiters) w.reject(new Error(`faultproxy exited with ${code}:\n${output}`));
      reject(new Error(`faultproxy exited with ${code}:\n${output}`));
    });
  });
}
