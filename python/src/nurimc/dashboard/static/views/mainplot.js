// The Plot view: one large plot of any signal of any motor, each unit on its own axis (° left,
// RPM and A right), the motors' samples aligned on one time axis (interpolated between each
// motor's own samples, so every series draws a line however many motors share the bus).
import { $, build, download } from "../core/dom.js";
import { num, onLanguage, t } from "../core/i18n.js";
import { seriesStyle, WINDOWS_S } from "../core/plotstyle.js";
import { alignTracks, csv, signalValue, windowStart } from "../core/series.js";
import { dashboard, on } from "../core/store.js";
import { WINDOW_S } from "./motors.js";
import { exportPng, makePlot, setPlotData } from "./plots.js";

export const SIGNALS = [
  { key: "position", unit: "°", digits: 2 },
  { key: "target", unit: "°", digits: 2 },
  { key: "error", unit: "°", digits: 2 },
  { key: "device", unit: "°", digits: 2 },
  { key: "speed", unit: "RPM", digits: 1 },
  { key: "current", unit: "A", digits: 1 },
];

const main = {
  plot: null,
  dirty: false,
  paused: false,
  zoomed: false,
  series: [],
  signals: new Set(["position"]),
  hidden: new Set(),
  windowS: WINDOW_S, // the time window shown (selectable)
};
dashboard.overlay = main;

const visible = () => !$("#view-plot").classList.contains("hidden");

function fillPickers() {
  $("#plot-signals").replaceChildren(
    ...SIGNALS.map((s) => {
      const box = build("input", { type: "checkbox", checked: main.signals.has(s.key), value: s.key });
      box.onchange = () => {
        if (box.checked) main.signals.add(s.key);
        else main.signals.delete(s.key);
        rebuild();
      };
      return build("label", { className: "pick" }, box, ` ${t(`signal.${s.key}`)} (${s.unit})`);
    }),
  );
  const ids = [...dashboard.motors.keys()].sort((a, b) => a - b);
  $("#plot-motors").replaceChildren(
    ...ids.map((id) => {
      const box = build("input", { type: "checkbox", checked: !main.hidden.has(id), value: id });
      box.onchange = () => {
        if (box.checked) main.hidden.delete(id);
        else main.hidden.add(id);
        rebuild();
      };
      return build("label", { className: "pick" }, box, ` ID ${id}`);
    }),
  );
}

export function rebuild() {
  main.plot?.destroy();
  main.plot = null;
  const box = $("#main-plot");
  box.replaceChildren();
  fillPickers();
  const all = [...dashboard.motors.keys()].sort((a, b) => a - b);
  const ids = all.filter((id) => !main.hidden.has(id));
  main.series = [];
  for (const id of ids)
    for (const signal of SIGNALS) if (main.signals.has(signal.key)) main.series.push({ id, signal });
  if (!main.series.length) return;
  main.plot = makePlot(box, {
    // a colour per motor (its place among all motors: it keeps it when others are hidden), a dash per signal
    series: main.series.map(({ id, signal }) => ({
      label: `ID ${id} ${t(`signal.${signal.key}`)}`,
      unit: signal.unit,
      ...seriesStyle(all.indexOf(id), signal.key),
      digits: signal.digits,
    })),
    height: Math.max(320, Math.min(560, Math.round(window.innerHeight * 0.55))),
    xLabel: t("plot.secondsNow"),
    onZoom: () => setPaused(true, true),
    onReset: () => setPaused(false),
  });
  main.dirty = true;
}

function setPaused(paused, zoomed = false) {
  main.paused = paused;
  main.zoomed = zoomed;
  $("#plot-pause").textContent = t(paused ? "plot.resume" : "plot.pause");
  $("#view-plot").dataset.paused = paused ? "yes" : "no";
  if (!paused) main.dirty = true;
}

function draw() {
  main.dirty = false;
  let now = -Infinity;
  for (const { id } of main.series) now = Math.max(now, dashboard.motors.get(id)?.latest ?? -Infinity);
  if (!Number.isFinite(now)) return;
  const tracks = main.series.map(({ id, signal }) => {
    const s = dashboard.motors.get(id)?.series;
    if (!s) return { t: [], v: [] };
    const from = windowStart(s.t, now, main.windowS);
    const times = s.t.slice(from);
    return { t: times, v: times.map((_, k) => signalValue(s, signal.key, from + k)) };
  });
  setPlotData(main.plot, alignTracks(tracks, now));
}

function exportCsv() {
  const rows = [];
  for (const [id, motor] of dashboard.motors) {
    const s = motor.series;
    for (let i = 0; i < s.t.length; i++)
      rows.push([
        id,
        s.t[i],
        s.position[i],
        s.target[i],
        signalValue(s, "error", i),
        s.device[i],
        s.speed[i],
        s.current[i],
      ]);
  }
  download(
    "nurimc-motors.csv",
    csv(
      [
        "motor_id",
        "t_s",
        "position_deg",
        "target_deg",
        "following_error_deg",
        "device_position_deg",
        "speed_rpm",
        "current_a",
      ],
      rows,
    ),
    "text/csv",
  );
}

export function startMainPlot() {
  on("motors", rebuild);
  on("samples", () => {
    main.dirty = true;
  });
  on("frame", () => {
    if (main.dirty && !main.paused && main.plot && visible()) draw();
  });
  on("view", (view) => {
    if (view === "plot") {
      main.dirty = true;
      if (main.plot && Math.abs(main.plot.width - $("#main-plot").clientWidth) > 2) rebuild();
    }
  });
  onLanguage(() => {
    rebuild();
    setPaused(main.paused, main.zoomed);
  });
  $("#plot-pause").onclick = () => setPaused(!main.paused);
  const windows = $("#plot-window");
  windows.replaceChildren(
    ...WINDOWS_S.map((s) => build("option", { value: String(s), textContent: `${s} s`, selected: s === main.windowS })),
  );
  windows.onchange = () => {
    main.windowS = Number(windows.value);
    main.dirty = true;
  };
  $("#plot-csv").onclick = exportCsv;
  $("#plot-png").onclick = () => main.plot && exportPng(main.plot, "nurimc-plot.png");
  rebuild();
}
export { num };
