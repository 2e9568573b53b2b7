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
  const child = spawn(NURIMC, ["dashboard", "--sim", "--listen", "127.0.0.1:0", ...extra], {
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

export async function launchBrowser() {
  if (!existsSync(CHROMIUM))
    throw new Error(`${CHROMIUM} is missing: run \`make system-deps\` (Debian package chromium)`);
  const profile = mkdtempSync(join(tmpdir(), "nurimc-e2e-"));
  return chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1280, height: 900 },
    args: [
      "--headless",
      "--no-sandbox",
      "--disable-gpu",
      "--disable-background-networking",
      "--disable-component-update",
      "--disable-sync",
      "--no-first-run",
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
