// Every banner message, in Korean and English, rendered with the console's own CSS in headless
// Chromium at 390 px (a phone) and 1,440 px (a laptop): it wraps by words, never one character a
// line (issue 38: a Korean error message was ~680 px tall, squeezed by its English detail), and is at most three lines tall at 390 px.
// The page itself from a static server (no bus): its banners, filled with each catalog text.
import assert from "node:assert/strict";
import { join } from "node:path";
import { after, before, test } from "node:test";
import { launchBrowser, ROOT, startStaticSite } from "./lib.mjs";
import { STATIC } from "./unit/paths.mjs";

const { CATALOGS, format } = await import(join(STATIC, "core/i18n.js"));
const FAMILIES = ["banner.", "estop.", "port.", "err."];
// plausible values for the placeholders (long where a real one can be long)
const PARAMS = {
  time: "오후 3:04:05",
  rates: "9600, 115200",
  list: "ID 1, ID 2, ID 3",
  port: "/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A10KZP3X-if00-port0",
  s: 12,
  seconds: 3,
  rate: 9600,
  reason: "connection refused",
  id: 3,
  n: 2,
  error: "EACCES",
};
const LINES_AT_PHONE = 3;

const messages = (lang) =>
  Object.entries(CATALOGS[lang])
    .filter(([key]) => FAMILIES.some((family) => key.startsWith(family)))
    .map(([key, text]) => [key, format(text, PARAMS)]);

// each banner of the page: its main text and its detail
const BANNERS = [
  ["#banner", "#banner-text", "#banner-detail"],
  ["#port-banner", "#port-banner-text", "#port-banner-detail"],
  ["#stop-banner", "#stop-banner-text", "#stop-banner-until"],
  ["#messages", "#messages .text", "#messages .detail"],
];

let context;
let site;
before(async () => {
  site = await startStaticSite(join(ROOT, "ts/dist/nurimc.browser.js"));
  context = await launchBrowser();
});
after(async () => {
  await context?.close();
  site?.stop();
});

for (const lang of ["ko", "en"]) {
  for (const width of [390, 1440]) {
    test(`${lang} banners at ${width} px wrap by words, at most ${LINES_AT_PHONE} lines at 390 px`, async () => {
      const tab = await context.newPage();
      await tab.setViewportSize({ width, height: 900 });
      await tab.goto(`${site.url}?lang=${lang}`);
      await tab.waitForSelector("#banner", { state: "attached" });
      const shown = messages(lang);
      assert.ok(shown.length > 20, `found the banner messages (${shown.length})`);
      const problems = [];
      for (const [key, text] of shown) {
        for (const [banner, box, detail] of BANNERS) {
          const got = await tab.evaluate(
            ({ banner, box, detail, text, english }) => {
              if (banner === "#messages") {
                // an error message as views/messages.js shows it: the text, the English original beside it
                document.querySelector(banner).innerHTML =
                  '<div class="message error"><span class="text"></span><code class="detail"></code>' +
                  '<span class="count"></span><button class="close">×</button></div>';
                document.querySelector(detail).textContent = english;
              }
              document.querySelector(banner).classList.remove("hidden");
              const node = document.querySelector(box);
              node.textContent = text;
              if (banner !== "#messages") document.querySelector(detail).textContent = text; // two long texts side by side
              const style = getComputedStyle(node);
              const line = Number.parseFloat(style.lineHeight) || Number.parseFloat(style.fontSize) * 1.4;
              const rect = node.getBoundingClientRect();
              return {
                lines: Math.round(rect.height / line),
                width: rect.width,
                fontSize: Number.parseFloat(style.fontSize),
              };
            },
            { banner, box, detail, text, english: format(CATALOGS.en[key], PARAMS) },
          );
          const chars = [...text].length;
          // never narrower than 8 characters unless the whole text is shorter
          if (got.width < Math.min(8 * got.fontSize, chars * got.fontSize * 0.5))
            problems.push(`${key} in ${box}: ${got.width.toFixed(0)} px wide (a character a line)`);
          if (width === 390 && got.lines > LINES_AT_PHONE)
            problems.push(`${key} in ${box}: ${got.lines} lines at 390 px`);
        }
      }
      await tab.close();
      assert.deepEqual(problems, []);
    });
  }
}
