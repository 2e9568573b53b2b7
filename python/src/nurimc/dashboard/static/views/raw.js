// Raw frames: every frame on the bus, decoded; filtered by ID, message and direction, the
// console's own polling hidden unless asked for; pause, search; export as a traffic log that
// `nurimc replay` reads.
//
// Kept responsive at the simulator's full polling rate (issue #37: 97 % of the main thread):
// frames are filtered once, as they come (not all 20,000 again on every refresh); only the rows
// in view are in the page (a virtualised list: a sizer gives the scroll height, a pool of rows
// is refilled); nothing is drawn while the view is hidden, paused or the tab is in the background.
import { $, build, download } from "../core/dom.js";
import { filterFrames, trafficLog } from "../core/frames.js";
import { num, onLanguage, t } from "../core/i18n.js";
import { dashboard, on } from "../core/store.js";
import { act, ask } from "./messages.js";

const KEEP = 20000;
const REFRESH_MS = 250; // new frames are shown at most this often
const OVERSCAN = 6; // rows drawn above and below the view
let dirty = false;
let seq = 0; // each frame's arrival number: what the filtered list has taken so far
let shown = []; // the frames passing the filters, oldest first
let shownKey = null; // the filters `shown` was made with
let taken = 0; // the last arrival number taken into `shown`
let rowHeight = 26; // measured from the rows drawn
const pool = []; // <tr> elements, reused
let scheduled = false;
let scheduledForFrames = false;
let language = 0; // bumped on a language change: every row is refilled

/** A message's name in the page's language (the vendor's words); its protocol name is shown beside it as code. */
const messageLabel = (name) => t(`message.${name}`);

const filters = () => ({
  id: $("#raw-id").value,
  message: $("#raw-message").value,
  dir: $("#raw-dir").value,
  search: $("#raw-search").value,
  polling: $("#raw-polling").checked,
});

const visible = () => !$("#view-raw").classList.contains("hidden") && !document.hidden;

function numbered(frames) {
  for (const f of frames) f.seq = ++seq;
  return frames;
}

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

/** Bring `shown` up to date: filtered afresh when the filters changed, else only the new frames. */
function update() {
  const wanted = filters();
  const key = JSON.stringify(wanted);
  const frames = dashboard.frames;
  if (key !== shownKey) {
    shown = filterFrames(frames, wanted);
    shownKey = key;
  } else {
    let i = frames.length;
    while (i > 0 && frames[i - 1].seq > taken) i--;
    if (i < frames.length) shown.push(...filterFrames(frames.slice(i), wanted));
    const oldest = frames.length ? frames[0].seq : Number.POSITIVE_INFINITY;
    let drop = 0;
    while (drop < shown.length && shown[drop].seq < oldest) drop++;
    if (drop) shown.splice(0, drop);
  }
  taken = frames.length ? frames[frames.length - 1].seq : taken;
}

function newRow() {
  const row = build("tr", {}, ...Array.from({ length: 6 }, () => build("td")));
  row.cells[3].append(document.createTextNode(""), build("code"));
  row.cells[4].append(build("code"));
  row.cells[5].append(build("code"));
  return row;
}

function fill(row, f) {
  if (row.frame === f && row.language === language) return;
  row.frame = f;
  row.language = language;
  row.className = f.dir;
  const [time, dir, id, message, fields, bytes] = row.cells;
  time.textContent = num(f.t, 4);
  dir.textContent = f.dir === "tx" ? t("raw.tx") : t("raw.rx");
  id.textContent = f.id ?? "";
  message.firstChild.textContent = `${messageLabel(f.name)} `;
  message.lastChild.textContent = f.name ?? "";
  fields.firstChild.textContent = JSON.stringify(f.fields);
  bytes.firstChild.textContent = f.hex;
}

function labels() {
  const heads = [...document.querySelectorAll("#raw-table thead th")].map((th) => th.textContent);
  for (const row of pool) for (const [i, cell] of [...row.cells].entries()) cell.dataset.label = heads[i];
}

/** Draw the rows in view (newest first) from `shown`. */
function render() {
  fillMessages();
  update();
  const total = shown.length;
  $("#raw-count").textContent = t("raw.count", { shown: num(total, 0), total: num(dashboard.frames.length, 0) });
  const viewport = $("#raw-viewport");
  const table = $("#raw-table");
  const head = table.tHead?.offsetHeight ?? 0;
  const height = viewport.clientHeight || 600;
  const first = Math.max(0, Math.floor(viewport.scrollTop / rowHeight) - OVERSCAN);
  const last = Math.min(total, first + Math.ceil(height / rowHeight) + 2 * OVERSCAN);
  const count = Math.max(0, last - first);
  const fresh = pool.length < count;
  while (pool.length < count) pool.push(newRow());
  if (fresh) labels();
  const body = table.tBodies[0];
  for (let k = 0; k < count; k++) fill(pool[k], shown[total - 1 - (first + k)]);
  if (body.children.length !== count) body.replaceChildren(...pool.slice(0, count));
  table.style.transform = `translateY(${first * rowHeight}px)`;
  if (count) rowHeight = Math.max(12, body.offsetHeight / count);
  $("#raw-sizer").style.height = `${Math.ceil(total * rowHeight + head)}px`;
}

/** Draw at the next frame. `forFrames`: only new frames asked for it, and new frames never
 * redraw a paused view (a redraw asked just before the pause is dropped, so the pause freezes what
 * the user saw); a filter, a scroll or the language still redraws it. */
function schedule(forFrames = false) {
  scheduledForFrames = scheduled ? scheduledForFrames && forFrames : forFrames;
  if (scheduled) return;
  scheduled = true;
  requestAnimationFrame(() => {
    scheduled = false;
    if (visible() && !(scheduledForFrames && $("#raw-pause").checked)) render();
  });
}

export function startRaw() {
  $("#raw-on").onchange = act(
    () => t("op.frames"),
    async (event) => {
      const result = await ask("frames", { on: event.target.checked });
      if (event.target.checked) {
        dashboard.frames = numbered(result.recent);
        shownKey = null;
        render();
      }
    },
  );
  for (const id of ["#raw-id", "#raw-search"]) $(id).oninput = () => schedule();
  for (const id of ["#raw-message", "#raw-dir", "#raw-polling"]) $(id).onchange = () => schedule();
  $("#raw-viewport").addEventListener("scroll", () => schedule(), { passive: true });
  $("#raw-export").onclick = () =>
    download("nurimc-traffic.log", trafficLog(filterFrames(dashboard.frames, filters())), "application/x-ndjson");
  on("frames", (frames) => {
    dashboard.frames.push(...numbered(frames));
    if (dashboard.frames.length > KEEP) dashboard.frames.splice(0, dashboard.frames.length - KEEP);
    dirty = true;
  });
  on("view", (view) => {
    if (view === "raw") schedule();
  });
  setInterval(() => {
    if (dirty && !$("#raw-pause").checked && visible()) {
      dirty = false;
      schedule(true);
    }
  }, REFRESH_MS);
  onLanguage(() => {
    language += 1;
    labels();
    shownKey = null;
    schedule();
  });
}
