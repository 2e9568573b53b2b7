// The console page: the language first, then the link (server or direct Web Serial), then the
// views. Each view is a module under views/; the pure parts (series, step figures, frame
// filters, motor state, catalogs) are under core/ and unit-tested (e2e/unit/).
import { $, $$ } from "./core/dom.js";
import { LANGUAGES, language, setLanguage, startLanguage, t } from "./core/i18n.js";
import { dashboard, emit } from "./core/store.js";
import { startBackup } from "./views/backup.js";
import { setStatus, startConnection, startLink } from "./views/connection.js";
import { startMainPlot } from "./views/mainplot.js";
import { say } from "./views/messages.js";
import { startMotors } from "./views/motors.js";
import { startPort } from "./views/port.js";
import { startRaw } from "./views/raw.js";
import { startSequence } from "./views/sequence.js";
import { startSettings } from "./views/settings.js";
import { startSetup } from "./views/setup.js";
import { startStep } from "./views/step.js";
import { startTune } from "./views/tune.js";

window.dashboard = dashboard;
dashboard.t = t; // for tests and the browser console

function startViews() {
  for (const button of $$("nav button")) {
    button.onclick = () => showView(button.dataset.view);
  }
}
export function showView(view) {
  for (const other of $$("nav button")) {
    other.classList.toggle("active", other.dataset.view === view);
    other.setAttribute("aria-selected", other.dataset.view === view ? "true" : "false");
  }
  for (const section of $$(".view")) section.classList.toggle("hidden", section.id !== `view-${view}`);
  dashboard.view = view;
  emit("view", view);
}

function startLanguageSwitch() {
  const select = $("#lang");
  select.value = language();
  select.onchange = () => setLanguage(select.value);
  dashboard.setLanguage = (lang) => {
    setLanguage(lang);
    select.value = language();
  };
  dashboard.languages = LANGUAGES;
}

startLanguage();
startLanguageSwitch();
startConnection();
startPort();
startMotors();
startMainPlot();
startSettings();
startStep();
startTune();
startSequence();
startSetup();
startBackup();
startRaw();
startViews();
document.addEventListener("input", (event) => event.target.removeAttribute?.("aria-invalid"));
window.addEventListener("unhandledrejection", (event) => {
  event.preventDefault(); // reported where it happened; never "Uncaught (in promise)"
  if (!event.reason?.reported) say(String(event.reason?.message ?? event.reason), "error");
});
startLink().catch((error) => setStatus("status.startFailed", { why: error.message }));
