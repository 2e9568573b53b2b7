// The Step response view: a position step drawn live while it records (from the motor's live
// samples), then the server's recording; runs overlaid with their gains and figures in a table;
// an A/B view of two runs; the position gains written, each one verified.
import { $, build, download } from "../core/dom.js";
import { num, onLanguage, t } from "../core/i18n.js";
import { readNumber } from "../core/input.js";
import { MOVE_LIMIT, RPM_MAX, settingSpec } from "../core/limits.js";
import { alignTracks, csv } from "../core/series.js";
import { stepFigures } from "../core/stepfigures.js";
import { dashboard, on } from "../core/store.js";
import { act, ask } from "./messages.js";
import { COLOURS, makePlot, setPlotData } from "./plots.js";

const STEP_KEEP = 8; // runs kept for comparison
const GAINS = ["kp", "ki", "kd"];
let plot = null;
let live = null; // the run being recorded: { id, start, target, t0 }
const ab = { a: null, b: null }; // runs compared (indexes into stepRuns), null: show every run

function shownRuns() {
  const runs = dashboard.stepRuns.map((run, index) => ({ run, index }));
  if (ab.a != null && ab.b != null) return runs.filter(({ index }) => index === ab.a || index === ab.b);
  return runs;
}

function rebuildPlot() {
  plot?.destroy();
  plot = null;
  const box = $("#step-plot");
  box.replaceChildren();
  const runs = shownRuns();
  const series = [
    { label: t("step.target"), unit: "°", stroke: "#6b7280", dash: [6, 4], width: 1.5 },
    ...runs.map(({ run, index }) => ({
      label: run.label,
      unit: "°",
      stroke: COLOURS[index % COLOURS.length],
      width: 2,
    })),
  ];
  if (live) series.push({ label: t("step.recording"), unit: "°", stroke: "#b91c1c", width: 2.5 });
  plot = makePlot(box, { series, height: 340, xLabel: t("step.seconds") });
  drawSteps();
}

function liveTrack() {
  if (!live) return null;
  const s = dashboard.motors.get(live.id)?.series;
  if (!s) return { t: [], v: [] };
  const times = [];
  const values = [];
  for (let i = 0; i < s.t.length; i++) {
    if (s.t[i] < live.t0) continue;
    times.push(s.t[i] - live.t0);
    values.push(s.position[i] - live.start);
  }
  return { t: times, v: values };
}

function drawSteps() {
  if (!plot) return;
  const runs = shownRuns().map(({ run }) => ({ t: run.times, v: run.positions.map((p) => p - run.start) }));
  const track = liveTrack();
  const all = track ? [...runs, track] : runs;
  const aligned = alignTracks(all);
  const x = aligned[0];
  const reference = live ?? dashboard.stepRuns.at(-1);
  const step = reference ? reference.target - reference.start : 0;
  setPlotData(plot, [x, x.map(() => step), ...aligned.slice(1)]);
  $("#step-plot").dataset.points = String(x.length);
}

function figuresOf(run) {
  return stepFigures(run.times, run.positions, run.start, run.target);
}

/** Each cell names its column (shown before it when the table is stacked on a phone). */
function labelCells(row, table) {
  const heads = [...document.querySelectorAll(`${table} thead th`)].map((th) => th.textContent);
  [...row.children].forEach((cell, i) => {
    if (heads[i]) cell.dataset.label = heads[i];
  });
}

function renderTable() {
  const body = $("#step-runs tbody");
  const ms = (s) => (s == null ? t("step.notReached") : `${num(s * 1000, 0)} ms`);
  const rows = dashboard.stepRuns.map((run, index) => {
    const f = figuresOf(run) ?? {};
    const pick = (which) => {
      const box = build("input", {
        type: "radio",
        name: `ab-${which}`,
        checked: ab[which] === index,
        ariaLabel: `${which.toUpperCase()} #${index + 1}`,
      });
      box.onchange = () => {
        ab[which] = index;
        rebuildPlot();
        renderTable();
      };
      return build("td", { className: "ab" }, box);
    };
    const row = build(
      "tr",
      {},
      build("td", { textContent: `#${index + 1}` }),
      build("td", { textContent: `ID ${run.id}` }),
      build("td", { textContent: `${num(run.amplitude, 1)}°` }),
      build("td", { textContent: run.gains }),
      build("td", { textContent: ms(run.rise_time ?? f.rise) }),
      build("td", { textContent: `${num(f.overshoot ?? run.overshoot, 1)} %` }),
      build("td", { textContent: f.settling == null ? t("step.notSettled") : ms(f.settling) }),
      build("td", { textContent: `${num(f.finalError ?? run.final_error, 2)}°` }),
      pick("a"),
      pick("b"),
    );
    row.style.setProperty("--run", COLOURS[index % COLOURS.length]);
    labelCells(row, "#step-runs");
    return row;
  });
  body.replaceChildren(...rows);
  $("#step-ab-clear").disabled = ab.a == null && ab.b == null;
  const diff = $("#step-ab");
  if (ab.a != null && ab.b != null && dashboard.stepRuns[ab.a] && dashboard.stepRuns[ab.b]) {
    const [fa, fb] = [ab.a, ab.b].map((i) => figuresOf(dashboard.stepRuns[i]) ?? {});
    diff.textContent = t("step.abDiff", {
      a: ab.a + 1,
      b: ab.b + 1,
      rise: fa.rise != null && fb.rise != null ? num((fb.rise - fa.rise) * 1000, 0) : "–",
      overshoot: num((fb.overshoot ?? 0) - (fa.overshoot ?? 0), 1),
      error: num((fb.finalError ?? 0) - (fa.finalError ?? 0), 2),
    });
  } else diff.textContent = t("step.abHint");
}

async function runStep() {
  const id = Number($("#step-motor").value);
  const amplitude = readNumber($("#step-amplitude"), t("step.step"), {
    min: -2 * MOVE_LIMIT,
    max: 2 * MOVE_LIMIT,
    nonzero: true,
  });
  const rpm = readNumber($("#step-rpm"), t("step.rpm"), { above: 0, max: RPM_MAX });
  const duration = readNumber($("#step-duration"), t("step.record"), { min: 0.2, max: 10 });
  const s = dashboard.motors.get(id)?.series;
  const start = s?.position.at(-1) ?? 0;
  live = { id, start, target: start + amplitude, t0: performance.now() / 1000 };
  $("#step-run").disabled = true;
  $("#step-figures").textContent = t("step.stepping");
  $("#step-plot").dataset.live = "yes";
  rebuildPlot();
  try {
    const r = await ask("step", { id, amplitude, rpm, duration });
    r.id = id;
    r.amplitude = amplitude;
    // the gains the motor had at the run's start (read by the server), not the typed fields
    r.gains = r.gains && typeof r.gains === "object" ? GAINS.map((k) => r.gains[k] ?? "?").join(" / ") : "?";
    r.label = `#${dashboard.stepRuns.length + 1} ID ${id} ${amplitude}° (${r.gains})`;
    dashboard.lastStep = r;
    dashboard.stepRuns.push(r);
    if (dashboard.stepRuns.length > STEP_KEEP) dashboard.stepRuns.shift();
    const f = figuresOf(r);
    $("#step-figures").textContent = t("step.figures", {
      rise: r.rise_time == null ? t("step.notReached") : `${num(r.rise_time * 1000, 0)} ms`,
      overshoot: num(r.overshoot, 1),
      settling: f?.settling == null ? t("step.notSettled") : `${num(f.settling * 1000, 0)} ms`,
      error: num(r.final_error, 3),
      settled: t(r.settled ? "step.settled" : "step.notSettled"),
    });
  } catch (error) {
    $("#step-figures").textContent = "";
    throw error;
  } finally {
    live = null;
    $("#step-plot").dataset.live = "no";
    $("#step-run").disabled = false;
    rebuildPlot();
    renderTable();
  }
}

async function prefillGains() {
  const id = Number($("#step-motor").value);
  if (!Number.isFinite(id) || !$("#step-motor").value) return;
  const answer = await ask("read_settings", { id });
  for (const k of GAINS) $(`#gain-${k}`).value = answer.settings[`position-${k}`];
  $("#gains-text").textContent = t("step.gainsRead", { id });
  dashboard.gainsShownFor = id;
}

async function writeGains() {
  const id = Number($("#step-motor").value);
  const gains = GAINS.map((k) => {
    const name = `position-${k}`;
    const spec = settingSpec(name);
    return [
      name,
      readNumber($(`#gain-${k}`), k === "kp" ? "Kp" : k === "ki" ? "Ki" : "Kd", {
        min: spec.physicalMin,
        max: spec.physicalMax,
        integer: true,
      }),
    ];
  });
  const done = [];
  $("#gains-text").textContent = t("step.gainsWriting");
  for (const [name, value] of gains) {
    const answer = await ask("set", { id, name, value });
    done.push(`${t(`setting.${name}`)} = ${answer.value}`);
  }
  $("#gains-text").textContent = t("step.gainsVerified", { id, list: done.join(", ") });
  $("#gains-text").dataset.written = gains.map(([name]) => name).join(",");
}

export function startStep() {
  for (const k of GAINS) {
    const spec = settingSpec(`position-${k}`);
    Object.assign($(`#gain-${k}`), { min: spec.physicalMin, max: spec.physicalMax });
  }
  $("#step-run").onclick = act(() => t("op.step"), runStep);
  $("#step-clear").onclick = () => {
    dashboard.stepRuns = [];
    ab.a = ab.b = null;
    rebuildPlot();
    renderTable();
  };
  $("#step-ab-clear").onclick = () => {
    ab.a = ab.b = null;
    rebuildPlot();
    renderTable();
  };
  $("#step-csv").onclick = () => {
    const rows = [];
    dashboard.stepRuns.forEach((r, k) => {
      r.times.forEach((time, i) => {
        rows.push([k + 1, r.id, r.gains, time, r.positions[i], r.start, r.target]);
      });
    });
    download(
      "nurimc-steps.csv",
      csv(["run", "motor_id", "gains_kp_ki_kd", "t_s", "position_deg", "start_deg", "target_deg"], rows),
      "text/csv",
    );
  };
  $("#step-motor").onchange = () => prefillGains().catch(() => {});
  $("#gains-write").onclick = act(() => t("op.gains"), writeGains);
  on("frame", () => {
    if (live) drawSteps();
  });
  on("view", (view) => {
    if (view === "step" && dashboard.connected && dashboard.motors.size) prefillGains().catch(() => {});
    if (view === "step") rebuildPlot();
  });
  onLanguage(() => {
    rebuildPlot();
    renderTable();
  });
  on("step-runs", () => {
    rebuildPlot(); // runs added elsewhere (the Auto-tune panel's trials)
    renderTable();
  });
  rebuildPlot();
  renderTable();
}
