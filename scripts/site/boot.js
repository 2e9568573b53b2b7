// The static site's entry (make site): the page for browsers without Web Serial, the service
// worker (installable; opens offline once loaded), and the notice when a new version was picked
// up on this load. Then the console itself (app.js), which finds no server here and runs in
// direct mode.
import { startLanguage, t } from "./core/i18n.js";
import { VERSION } from "./version.js";

const SEEN = "nurimc.site.version";

function unsupported() {
  document.title = t("site.unsupported.title");
  const main = document.createElement("main");
  main.className = "site-unsupported";
  main.id = "unsupported";
  const add = (tag, text) => {
    const element = document.createElement(tag);
    element.textContent = text;
    main.append(element);
    return element;
  };
  add("h1", t("site.unsupported.title"));
  add("p", t("site.unsupported.why"));
  add("p", t("site.unsupported.browsers"));
  add("p", t("site.unsupported.python"));
  const code = add("pre", "pip install nurimc\nnurimc --port COM3 dashboard");
  code.className = "site-code";
  document.body.replaceChildren(main);
}

async function serviceWorker() {
  if (!("serviceWorker" in navigator)) return;
  try {
    await navigator.serviceWorker.register("./sw.js", { scope: "./" });
  } catch {
    // not installable here (e.g. plain http on another host): the page still works online
  }
}

startLanguage();
serviceWorker();
document.documentElement.dataset.siteVersion = VERSION;
if (!("serial" in navigator)) {
  unsupported();
} else {
  await import("./app.js");
  const before = localStorage.getItem(SEEN);
  localStorage.setItem(SEEN, VERSION);
  if (before && before !== VERSION) {
    const { say } = await import("./views/messages.js");
    say(t("site.updated", { version: VERSION }), "info");
    document.documentElement.dataset.updatedFrom = before;
  }
}
