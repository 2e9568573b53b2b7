// The browser bundle for the console's direct mode: one ESM file, no Node modules.
// Usage: node scripts/bundle.mjs [outfile]   (default dist/nurimc.browser.js)

import { fileURLToPath } from "node:url";
import { build } from "esbuild";

export async function bundle(outfile) {
  await build({
    entryPoints: [fileURLToPath(new URL("../src/index.ts", import.meta.url))],
    outfile,
    bundle: true,
    format: "esm",
    platform: "browser",
    target: "es2022",
    sourcemap: true,
    logLevel: "warning",
  });
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  await bundle(process.argv[2] ?? fileURLToPath(new URL("../dist/nurimc.browser.js", import.meta.url)));
}
