// Message catalogs (locales/en.js, locales/ko.js): every visible string of the page comes from
// here. The language follows the browser (navigator.languages, which Chromium also sends as
// Accept-Language) unless the user picked one with the switch; the pick is remembered.
import en from "../locales/en.js";
import ko from "../locales/ko.js";

export const CATALOGS = Object.freeze({ en, ko });
export const LANGUAGES = Object.freeze(Object.keys(CATALOGS));
const STORE_KEY = "nurimc.lang";

let current = "en";
const listeners = [];

/** The language to use: a remembered pick, else the first of the browser's languages we have, else English. */
export function pickLanguage(browserLanguages = [], remembered = null) {
  if (remembered && LANGUAGES.includes(remembered)) return remembered;
  for (const tag of browserLanguages ?? []) {
    const base = String(tag).toLowerCase().split("-")[0];
    if (LANGUAGES.includes(base)) return base;
  }
  return "en";
}

/** Fill {name} placeholders of a catalog entry. */
export function format(template, params = {}) {
  return template.replace(/\{(\w+)\}/g, (whole, name) => (name in params ? String(params[name]) : whole));
}

/** The text of `key` in `lang` (default: the page's language); a missing key shows the key itself, loudly. */
export function translate(lang, key, params) {
  const text = CATALOGS[lang]?.[key] ?? CATALOGS.en[key];
  if (text === undefined) return `⟦${key}⟧`;
  return format(text, params);
}
export const t = (key, params) => translate(current, key, params);

export const language = () => current;
export const locale = () => (current === "ko" ? "ko-KR" : "en-US");

/** A number for the page's locale with a fixed number of decimals ("–" for none). */
export function num(value, digits = 2, lang = current) {
  if (value == null || !Number.isFinite(value)) return "–";
  return new Intl.NumberFormat(lang === "ko" ? "ko-KR" : "en-US", {
    minimumFractionDigits: digits,
    maximumFractionDigits: digits,
  }).format(value);
}

/** A clock time for the page's locale. */
export function clock(date = new Date(), lang = current) {
  return new Intl.DateTimeFormat(lang === "ko" ? "ko-KR" : "en-US", { timeStyle: "medium" }).format(date);
}

/** Translate every element marked with data-i18n (text), data-i18n-title, -placeholder, -aria-label. */
export function applyTranslations(root = document) {
  for (const node of root.querySelectorAll("[data-i18n]")) node.textContent = t(node.dataset.i18n);
  for (const node of root.querySelectorAll("[data-i18n-html]")) {
    // only catalog text with <kbd>/<b> marks, never data from outside
    node.innerHTML = t(node.dataset.i18nHtml);
  }
  for (const [attr, data] of [
    ["title", "i18nTitle"],
    ["placeholder", "i18nPlaceholder"],
    ["aria-label", "i18nAriaLabel"],
  ])
    for (const node of root.querySelectorAll(`[data-${attr === "aria-label" ? "i18n-aria-label" : `i18n-${attr}`}]`))
      node.setAttribute(attr, t(node.dataset[data]));
}

/** Switch the page's language (remembered); views re-render through onLanguage listeners. */
export function setLanguage(lang, { remember = true } = {}) {
  current = LANGUAGES.includes(lang) ? lang : "en";
  if (remember) {
    try {
      localStorage.setItem(STORE_KEY, current);
    } catch {
      /* private mode: the pick lasts this page */
    }
  }
  document.documentElement.lang = current;
  document.title = t("app.title");
  applyTranslations();
  for (const listener of listeners) listener(current);
}
/** Call `listener(lang)` after every language switch; returns a function that stops it. */
export function onLanguage(listener) {
  listeners.push(listener);
  return () => {
    const i = listeners.indexOf(listener);
    if (i >= 0) listeners.splice(i, 1);
  };
}

export function startLanguage() {
  let remembered = null;
  try {
    remembered = localStorage.getItem(STORE_KEY);
  } catch {
    remembered = null;
  }
  setLanguage(pickLanguage(navigator.languages ?? [navigator.language], remembered), { remember: false });
}

// ---- errors the server (or the TS library) sends in English, shown in the page's language ----
// Each rule: a pattern of the library's English message and the catalog key that says it.
const ERROR_RULES = [
  [/another product line/i, "err.otherLine"],
  [/needs the Python console|the Python console \(nurimc backup\)/i, "err.lineNeedsPython"],
  [/^incomplete restore of /i, "err.incompleteRestore", (m) => ({ file: m.match(/of (.+?): /)?.[1] ?? "?" })],
  [
    /not a nurimc backup|between the wire's steps|not a setting|appears twice|unknown field|a backup holds/i,
    "err.badBackup",
  ],
  [/serial port failed|serial port is closed|writing to the serial port failed|unplugged/i, "err.portGone"],
  [/^stop pending/i, "err.stopPending"],
  [/cannot reopen/i, "err.cannotReopen"],
  [/^port \S+ is lost|port lost/i, "err.portLost"],
  [/before emergency stop/i, "err.beforeStop"],
  [/cancelled by an emergency stop|cancelled/i, "err.cancelled"],
  [/^busy: /i, "err.busyQueue"],
  [/is busy writing its settings/i, "err.busyEeprom", (m) => ({ id: m.match(/ID (\d+)/)?.[1] ?? "?" })],
  [/no answer/i, "err.noAnswer", (m) => ({ id: m.match(/ID (\d+)/)?.[1] ?? "?" })],
  [/server unreachable|connection to the server was lost/i, "err.unreachable"],
  [/already answers|is taken|taken/i, "err.idTaken"],
  [/outside the device|device.s range|degrees .*out of range/i, "err.moveRange"],
  [/out of range|must be|between/i, "err.range"],
  [/simulated bus/i, "err.simPort"],
  [/needs the server/i, "err.needsServer"],
  [/not connected/i, "err.notConnected"],
];

/** An English message from the server or library in the page's language: {text, detail}.
 *  `detail` keeps the original (shown in a <code> for bug reports) when the page's language is not English. */
export function serverError(message, lang = current) {
  const text = String(message ?? "");
  if (lang === "en") return { text, detail: "" };
  for (const [pattern, key, params] of ERROR_RULES) {
    if (pattern.test(text)) return { text: translate(lang, key, params ? params(text) : {}), detail: text };
  }
  return { text: translate(lang, "err.other"), detail: text };
}
