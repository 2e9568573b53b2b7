// Raw frames: every frame on the bus, decoded; filtered by ID, message and direction, the
// console's own polling hidden unless asked for; pause, search; export as a traffic log that
// `nurimc replay` reads.
import { $, build, download } from "../core/dom.js";
import { filterFrames, trafficLog } from "../core/frames.js";
import { num, onLanguage, t } from "../core/i18n.js";
import { dashboard, on } from "../core/store.js";
import { act, ask } from "./messages.js";

const RAW_ROWS = 500; // rows shown (all kept frames are exported)
const KEEP = 20000;
let dirty = false;

/** A message's name in the page's language (the vendor's words); its protocol name is shown beside it as code. */
const messageLabel = (name) => t(`message.${name}`);

const filters = () => ({
  id: $("#raw-id").value,
  message: $("#raw-message").value,
  dir: $("#raw-dir").value,
  search: $("#raw-search").value,
  polling: $("#raw-polling").checked,
});

function fillMessages() {
  const select = $("#raw-message");
  const chosen = select.value;
  const names = [...new Set(dashboard.frames.map((f) => f.name).filter(Boolean))].sort();
  if (chosen && !names.includes(chosen)) names.push(chosen);
  const same = select.options.length === names.length + 1 && names.every((n, i) => select.options[i + 1].value === n);
  if (
    same &&
    select.options[0].textContent === t("raw.anyMessage") &&
    select.options[names.length]?.textContent === messageLabel(names.at(-1))
  )
    return;
  select.replaceChildren(
    build("option", { value: "", textContent: t("raw.anyMessage") }),
    ...names.map((n) => build("option", { value: n, textContent: messageLabel(n) })),
  );
  select.value = chosen;
}

function render() {
  fillMessages();
  const frames = filterFrames(dashboard.frames, filters());
  $("#raw-count").textContent = t("raw.count", {
    shown: num(frames.length, 0),
    total: num(dashboard.frames.length, 0),
  });
  const rows = frames
    .slice(-RAW_ROWS)
    .reverse()
    .map((f) =>
      build(
        "tr",
        { className: f.dir },
        build("td", { textContent: num(f.t, 4) }),
        build("td", { textContent: f.dir === "tx" ? t("raw.tx") : t("raw.rx") }),
        build("td", { textContent: f.id ?? "" }),
        build("td", {}, `${messageLabel(f.name)} `, build("code", { textContent: f.name })),
        build("td", {}, build("code", { textContent: JSON.stringify(f.fields) })),
        build("td", {}, build("code", { textContent: f.hex })),
      ),
    );
  const heads = [...document.querySelectorAll("#raw-table thead th")].map((th) => th.textContent);
  for (const row of rows) for (const [i, cell] of [...row.children].entries()) cell.dataset.label = heads[i];
  $("#raw-table tbody").replaceChildren(...rows);
}

export function startRaw() {
  $("#raw-on").onchange = act(
    () => t("op.frames"),
    async (event) => {
      const result = await ask("frames", { on: event.target.checked });
      if (event.target.checked) {
        dashboard.frames = result.recent;
        render();
      }
    },
  );
  for (const id of ["#raw-id", "#raw-search"]) $(id).oninput = render;
  for (const id of ["#raw-message", "#raw-dir", "#raw-polling"]) $(id).onchange = render;
  $("#raw-export").onclick = () =>
    download("nurimc-traffic.log", trafficLog(filterFrames(dashboard.frames, filters())), "application/x-ndjson");
  on("frames", (frames) => {
    dashboard.frames.push(...frames);
    if (dashboard.frames.length > KEEP) dashboard.frames.splice(0, dashboard.frames.length - KEEP);
    dirty = true;
  });
  setInterval(() => {
    if (dirty && !$("#raw-pause").checked && !$("#view-raw").classList.contains("hidden")) {
      dirty = false;
      render();
    }
  }, 250);
  onLanguage(render);
}
