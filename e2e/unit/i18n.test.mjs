// The catalogs: both languages have every key with the same placeholders, every key the page
// uses exists, the families of keys cover what they name, and language and errors are picked right.
import assert from "node:assert/strict";
import { readdirSync, readFileSync } from "node:fs";
import { join } from "node:path";
import { test } from "node:test";
import { STATIC } from "./paths.mjs";

const { CATALOGS, pickLanguage, serverError, translate, format } = await import(join(STATIC, "core/i18n.js"));
const { SETTINGS } = await import(join(STATIC, "generated/spec.js"));
const { SIGNALS } = { SIGNALS: ["position", "target", "error", "device", "speed", "current"] };

const placeholders = (text) => [...text.matchAll(/\{(\w+)\}/g)].map((m) => m[1]).sort();
const pageFiles = () => [
  "app.js",
  "index.html",
  "direct-link.js",
  ...readdirSync(join(STATIC, "views")).map((f) => `views/${f}`),
  ...readdirSync(join(STATIC, "core")).map((f) => `core/${f}`),
];

test("every key is in both catalogs, with the same placeholders, none empty", () => {
  const { en, ko } = CATALOGS;
  assert.deepEqual(Object.keys(ko).sort(), Object.keys(en).sort(), "the same keys");
  for (const key of Object.keys(en)) {
    assert.deepEqual(placeholders(ko[key]), placeholders(en[key]), `${key}: placeholders`);
    assert.ok(en[key].trim() && ko[key].trim(), `${key}: not empty`);
  }
});

test("the Korean catalog is Korean (Hangul in every entry that has words, apart from units and names)", () => {
  const exempt = new Set([
    "state.unknown",
    "seq.field.id",
    "seq.field.rpm",
    "plot.csv",
    "plot.png",
    "line.rsavw",
    "line.sm",
  ]); // product names
  for (const [key, text] of Object.entries(CATALOGS.ko)) {
    if (exempt.has(key)) continue;
    if (
      /[A-Za-z]{3,}/.test(
        text.replace(
          /\{\w+\}|<\/?\w+>|nurimc\.browser\.js|nurimc-sequence\/1|nurimc( dashboard)?|Web Serial|Python|ChromeOS|Chromium|Chrome|Edge|Firefox|Safari|Windows|macOS|Linux|USB-RS485|USB|https?:\/\/|localhost|JSON|CSV|PNG|EEPROM|RPM|bps|Kp|Ki|Kd|BLMC-H|RSAVW|RSA|MC|Esc|Shift|ID|CCW|CW|--port|nurimc\.browser\.js|docs\/dashboard\.md|nurimc-sequence\/1|ms|µs/g,
          "",
        ),
      )
    )
      assert.fail(`${key}: English left in ${JSON.stringify(text)}`);
    if (/[A-Za-z]/.test(text) || text.length > 3)
      assert.match(text, /[\uac00-\ud7a3]/, `${key}: no Hangul in ${JSON.stringify(text)}`);
  }
});

test("the vendor's Korean terms are used for the settings", () => {
  const ko = CATALOGS.ko;
  assert.match(ko["setting.position-kp"], /^위치제어기/);
  assert.match(ko["setting.speed-kp"], /^속도제어기/);
  assert.equal(ko["setting.position-rated-current"], "위치제어 정격전류");
  assert.equal(ko["setting.ratio"], "감속비");
  assert.equal(ko["setting.response-time"], "통신 응답시간");
  assert.equal(ko["setting.resolution"], "분해능");
  assert.equal(ko["setting.rated-speed"], "모터 정격속도");
});

test("every key the page uses exists, and each family covers what it names", () => {
  const en = CATALOGS.en;
  const missing = [];
  for (const file of pageFiles()) {
    const text = readFileSync(join(STATIC, file), "utf8");
    for (const m of text.matchAll(/\bt\(\s*"([\w.-]+)"/g)) if (!(m[1] in en)) missing.push(`${file}: ${m[1]}`);
    for (const m of text.matchAll(/data-i18n(?:-[a-z-]+)?="([\w.-]+)"/g))
      if (!(m[1] in en)) missing.push(`${file}: ${m[1]}`);
    for (const m of text.matchAll(
      /"((?:err|estop|banner|status|seq|setup|step|motors|settings|raw|plot|bar|mode|input|msg)\.[\w.]+)"/g,
    ))
      if (!(m[1] in en)) missing.push(`${file}: ${m[1]}`);
  }
  for (const s of SETTINGS) {
    for (const family of ["setting", "settingDoc"])
      if (!(`${family}.${s.name}` in en)) missing.push(`${family}.${s.name}`);
    for (const value of Object.values(s.values ?? {})) if (!(`choice.${value}` in en)) missing.push(`choice.${value}`);
  }
  for (const state of ["stopped", "busy", "silent", "off", "on", "moving", "unknown"])
    if (!(`state.${state}` in en)) missing.push(`state.${state}`);
  for (const signal of SIGNALS) if (!(`signal.${signal}` in en)) missing.push(`signal.${signal}`);
  const ops = new Set();
  for (const file of pageFiles())
    for (const m of readFileSync(join(STATIC, file), "utf8").matchAll(/ask\("(\w+)"/g)) ops.add(m[1]);
  for (const op of ops) if (!(`op.${op}` in en)) missing.push(`op.${op}`);
  assert.deepEqual(missing, []);
});

test("the language follows the browser unless one was picked", () => {
  assert.equal(pickLanguage(["ko-KR", "en-US"]), "ko");
  assert.equal(pickLanguage(["de-DE", "ko"]), "ko");
  assert.equal(pickLanguage(["en-GB", "ko"]), "en");
  assert.equal(pickLanguage(["fr"]), "en");
  assert.equal(pickLanguage([]), "en");
  assert.equal(pickLanguage(["ko-KR"], "en"), "en", "a remembered pick wins");
  assert.equal(pickLanguage(["ko-KR"], "xx"), "ko", "an unknown remembered pick is ignored");
});

test("the server's English errors are said in Korean, the original kept", () => {
  for (const [message, expected] of [
    ["refused: sent before emergency stop 3", "err.beforeStop"],
    ["busy: 256 commands are waiting; try again shortly", "err.busyQueue"],
    ["ID 2 is busy writing its settings (EEPROM); readings resume in a moment", "err.busyEeprom"],
    ["move.degrees = 700.0 is out of range; allowed: -655.33..655.33 deg", "err.moveRange"],
    ["no answer to request_position to ID 7 after 3 attempt(s)", "err.noAnswer"],
    ["something nobody planned for", "err.other"],
  ]) {
    const { text, detail } = serverError(message, "ko");
    assert.equal(text, translate("ko", expected, { id: message.match(/ID (\d+)/)?.[1] ?? "?" }), message);
    assert.equal(detail, message);
  }
  assert.deepEqual(
    serverError("anything", "en"),
    { text: "anything", detail: "" },
    "English stays as the server said it",
  );
  assert.equal(format("{a} and {b}", { a: 1 }), "1 and {b}");
});

test("direct mode's messages (the TS library and direct-ops.js) are said in Korean too", () => {
  const cases = [
    [
      "robot.json: ID 7 in the backup is mc (mc line) but the controller speaks the rsa line: a file from another product line; nothing was written",
      "err.otherLine",
    ],
    [
      "ID 7 speaks the rsa line: reading and writing it needs the Python console (nurimc dashboard) in this version",
      "err.lineNeedsPython",
    ],
    [
      "incomplete restore of robot.json: restore it again (only what still differs is written)",
      "err.incompleteRestore",
    ],
    [
      "robot.json: motors[0] (ID 1): settings.ratio: 1.05 is between the wire's steps; the nearest is 1.1",
      "err.badBackup",
    ],
    ["writing to the serial port failed (unplugged?): NetworkError: The device has been lost.", "err.portGone"],
  ];
  for (const [message, key] of cases) {
    const { text, detail } = serverError(message, "ko");
    assert.equal(text, translate("ko", key, key === "err.incompleteRestore" ? { file: "robot.json" } : {}), message);
    assert.equal(detail, message);
  }
});
