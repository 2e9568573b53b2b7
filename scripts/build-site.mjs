// make site: the console as a static site in site/ (no server): the page, the TypeScript
// library's browser bundle, the vendored uPlot, a web app manifest and a service worker.
// Serve site/ with any static server (python3 -m http.server -d site) on localhost or https.
// Needs ts/dist/nurimc.browser.js (make -f ts/Makefile.inc ts-build) and the vendored uPlot
// (scripts/dashboard-assets.sh); `make site` runs both first.
import { createHash } from "node:crypto";
import { cpSync, existsSync, mkdirSync, readdirSync, readFileSync, rmSync, statSync, writeFileSync } from "node:fs";
import { dirname, join, relative } from "node:path";
import { fileURLToPath } from "node:url";

const ROOT = join(dirname(fileURLToPath(import.meta.url)), "..");
const STATIC = join(ROOT, "python/src/nurimc/dashboard/static");
const BUNDLE = join(ROOT, "ts/dist/nurimc.browser.js");
const OWN = join(ROOT, "scripts/site");
const OUT = join(ROOT, process.env.SITE_DIR ?? "site");

const fail = (message) => {
  console.error(`make site: ${message}`);
  process.exit(1);
};
if (!existsSync(BUNDLE)) fail(`${relative(ROOT, BUNDLE)} is missing: run make -f ts/Makefile.inc ts-build`);
if (!existsSync(join(STATIC, "vendor/uplot/uPlot.esm.js")))
  fail("uPlot is missing: run bash scripts/dashboard-assets.sh");

rmSync(OUT, { recursive: true, force: true });
mkdirSync(OUT, { recursive: true });
cpSync(STATIC, OUT, { recursive: true, filter: (path) => !path.endsWith("nurimc.browser.js") });
cpSync(BUNDLE, join(OUT, "nurimc.browser.js"));
for (const name of ["boot.js", "site.css", "manifest.webmanifest"]) cpSync(join(OWN, name), join(OUT, name));

// the page: the manifest and the site's entry (boot.js, which loads app.js); no inline script or style
const indexPath = join(OUT, "index.html");
let index = readFileSync(indexPath, "utf8");
const entry = '<script type="module" src="./app.js"></script>';
if (!index.includes(entry) || !index.includes("</head>")) fail("index.html has no app.js entry or </head>");
index = index
  .replace(entry, '<script type="module" src="./boot.js"></script>')
  .replace(
    "</head>",
    '<link rel="manifest" href="./manifest.webmanifest">\n<meta name="theme-color" content="#1f6feb">\n' +
      '<link rel="stylesheet" href="./site.css">\n</head>',
  );
writeFileSync(indexPath, index);

const files = [];
const walk = (dir) => {
  for (const name of readdirSync(dir).sort()) {
    const path = join(dir, name);
    if (statSync(path).isDirectory()) walk(path);
    else files.push(relative(OUT, path).split("\\").join("/"));
  }
};
walk(OUT);
const hash = createHash("sha256");
for (const file of files) hash.update(file).update(readFileSync(join(OUT, file)));
const version = hash.digest("hex").slice(0, 12);
writeFileSync(join(OUT, "version.js"), `export const VERSION = ${JSON.stringify(version)};\n`);
const kept = ["./", ...files, "version.js"].map((f) => (f === "./" ? f : `./${f}`));
writeFileSync(
  join(OUT, "sw.js"),
  readFileSync(join(OWN, "sw.js"), "utf8")
    .replace('"__VERSION__"', JSON.stringify(version))
    .replace("__FILES__", JSON.stringify(kept)),
);
console.log(`site/ built: version ${version}, ${kept.length} files kept offline by the service worker`);
