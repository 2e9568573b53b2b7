// uPlot for the page: plots that fill their box, legends that show the latest values (not "--")
// when the cursor is elsewhere, values under the cursor, drag to zoom (pauses), double-click to
// reset, wheel/drag-free pan through the zoom, and PNG export.
import { download } from "../core/dom.js";
import { num, t } from "../core/i18n.js";
import uPlot from "../vendor/uplot/uPlot.esm.js";

// one colour per series of a plot, so each can be told apart (and counted in the tests)
export const COLOURS = [
  "#2457c5",
  "#d97706",
  "#059669",
  "#7c3aed",
  "#db2777",
  "#0891b2",
  "#65a30d",
  "#b91c1c",
  "#4b5563",
  "#ca8a04",
  "#0d9488",
  "#9333ea",
  "#e11d48",
  "#1d4ed8",
  "#15803d",
];

/** Unit -> its scale and axis side; the first unit in use gets the left axis. */
export const UNIT_SCALES = { "°": "deg", RPM: "rpm", A: "amp" };

const lastValue = (data) => {
  for (let i = data.length - 1; i >= 0; i--) if (data[i] != null) return data[i];
  return null;
};

/** A series' legend value: under the cursor, else the latest drawn value (never "--"). */
export function valueShown(digits) {
  return (u, v, sidx, idx) => {
    const value = idx == null ? lastValue(u.data[sidx] ?? []) : v;
    return value == null ? "–" : num(value, digits);
  };
}

/**
 * A plot in `box`: series [{label, unit, stroke, dash, digits, width}], x in seconds.
 * owner: { paused, zoomed } is told when a drag zooms (it pauses) and a double-click resets.
 */
/** Tick labels with as many decimals as the tick spacing needs, in the page's locale. */
export function tickLabels(ticks) {
  const step = ticks.length > 1 ? Math.abs(ticks[1] - ticks[0]) : 1;
  const digits = step >= 1 ? 0 : step >= 0.1 ? 1 : step >= 0.01 ? 2 : 3;
  return ticks.map((v) => num(v, digits));
}

/** A colour of the page's theme (light or dark, following the system: app.css). */
const themed = (name, fallback) => getComputedStyle(document.documentElement).getPropertyValue(name).trim() || fallback;

export function makePlot(box, { series, height = 260, xLabel, onZoom, onReset }) {
  const units = [...new Set(series.map((s) => s.unit))];
  const ink = themed("--text", "#1c2330");
  const grid = { stroke: themed("--line", "#d8dce3"), width: 1 };
  const axes = [
    { label: xLabel, values: (_u, ticks) => tickLabels(ticks), stroke: ink, grid, ticks: grid },
    ...units.map((unit, i) => ({
      stroke: ink,
      ticks: grid,
      scale: UNIT_SCALES[unit] ?? unit,
      label: unit,
      side: i === 0 ? 3 : 1,
      grid: { ...grid, show: i === 0 },
      size: 56,
      values: (_u, ticks) => tickLabels(ticks),
    })),
  ];
  const scales = { x: { time: false } };
  for (const unit of units) scales[UNIT_SCALES[unit] ?? unit] = {};
  const plot = new uPlot(
    {
      width: Math.max(box.clientWidth, 240),
      height,
      legend: { live: true },
      cursor: { drag: { x: true, y: false } },
      scales,
      series: [
        {
          label: t("plot.t"),
          value: (u, v, _sidx, idx) => {
            const time = idx == null ? lastValue(u.data[0] ?? []) : v; // the latest, like the other series
            return time == null ? "–" : `${num(time, 2)} s`;
          },
        },
        ...series.map((s) => ({
          label: s.label,
          scale: UNIT_SCALES[s.unit] ?? s.unit,
          stroke: s.stroke,
          dash: s.dash,
          width: s.width ?? 2,
          spanGaps: false,
          value: valueShown(s.digits ?? 2),
        })),
      ],
      axes,
      hooks: {
        setSelect: [
          (u) => {
            if (u.select.width > 2) onZoom?.();
          },
        ],
      },
    },
    [[], ...series.map(() => [])],
    box,
  );
  plot.over.addEventListener("dblclick", () => onReset?.());
  // the wheel zooms the time axis around the cursor; with Shift it pans (both pause, like a drag)
  plot.over.addEventListener(
    "wheel",
    (event) => {
      const { min, max } = plot.scales.x;
      if (min == null || max == null) return;
      event.preventDefault();
      const span = max - min;
      if (event.shiftKey) {
        const shift = (Math.sign(event.deltaY || event.deltaX) * span) / 10;
        plot.setScale("x", { min: min + shift, max: max + shift });
      } else {
        const at = plot.posToVal(event.offsetX, "x");
        const factor = event.deltaY < 0 ? 0.8 : 1.25;
        plot.setScale("x", { min: at - (at - min) * factor, max: at + (max - at) * factor });
      }
      onZoom?.();
    },
    { passive: false },
  );
  const observer = new ResizeObserver(() => {
    const width = Math.max(box.clientWidth, 200);
    if (Math.abs(width - plot.width) > 2) plot.setSize({ width, height });
  });
  observer.observe(box);
  const destroy = plot.destroy.bind(plot);
  plot.destroy = () => {
    observer.disconnect();
    destroy();
  };
  return plot;
}

/** New data; the legend keeps showing the latest values while the cursor is away. */
export function setPlotData(plot, data, { keepZoom = false } = {}) {
  plot.setData(data, !keepZoom);
  if (plot.cursor.idx == null) plot.setLegend();
}

/** The plot as a PNG (its canvas on white, with the legend's text drawn below). */
export function exportPng(plot, name) {
  const source = plot.ctx.canvas;
  const lines = plot.series.slice(1).map((s, i) => `${s.label}: ${plot.legend.values?.[i + 1]?._ ?? ""}`);
  const canvas = document.createElement("canvas");
  canvas.width = source.width;
  canvas.height = source.height + 20 * lines.length + 10;
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = "#fff";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.drawImage(source, 0, 0);
  ctx.font = "14px sans-serif";
  lines.forEach((line, i) => {
    ctx.fillStyle = plot.series[i + 1].stroke?.() ?? "#000";
    ctx.fillText(line, 10, source.height + 20 * (i + 1));
  });
  canvas.toBlob((blob) => download(name, blob, "image/png"));
}
