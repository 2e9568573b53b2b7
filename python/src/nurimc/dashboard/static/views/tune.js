// The Auto-tune panel of the Step response view (issue 35): the server's tuner searches the
// position loop's gains with small steps inside an envelope; each trial is drawn as it ends and
// becomes a row of the runs table; Cancel stops it (the starting gains are written back); Apply
// writes the chosen gains, each verified. The tuner needs the server (it runs on the bus thread).
import { $ } from "../core/dom.js";
import { num, t } from "../core/i18n.js";
import { readNumber } from "../core/input.js";
import { dashboard, emit, on } from "../core/store.js";
import { act, ask, say } from "./messages.js";

const GAINS = ["kp", "ki", "kd"];
const state = { running: false, result: null, id: null };

function gainsText(gains) {
  return GAINS.map((k) => gains?.[k] ?? "?").join(" / ");
}

function figureText(trial) {
  if (trial.aborted) return t("tune.aborted", { why: trial.aborted });
  const f = trial.figures ?? {};
  return t("tune.trialFigures", {
    overshoot: num(f.overshoot ?? 0, 1),
    settling: f.settling_time == null ? t("step.notSettled") : `${num(f.settling_time * 1000, 0)} ms`,
  });
}

/** A finished trial becomes a run of the step view (plot and table). */
function addRun(event) {
  const gains = gainsText(event.gains);
  const f = event.figures ?? {};
  const run = {
    id: event.id,
    amplitude: event.target - event.start,
    gains,
    label: `${t("tune.trial", { n: event.trial })} (${gains})`,
    times: [0, ...event.times],
    positions: [event.start, ...event.values],
    start: event.start,
    target: event.target,
    rise_time: f.rise_time ?? null,
    overshoot: f.overshoot ?? 0,
    settled: f.settling_time != null,
    final_error: f.final_error ?? 0,
    tune: true,
  };
  dashboard.stepRuns.push(run);
  while (dashboard.stepRuns.length > Math.max(8, dashboard.tuneTrials?.length ?? 0)) dashboard.stepRuns.shift();
  emit("step-runs");
}

function onEvent(event) {
  if (event.event === "start") {
    $("#tune-progress").max = event.budget;
    $("#tune-progress").value = event.trial - 1;
    $("#tune-text").textContent = t("tune.running", {
      n: event.trial,
      total: event.budget,
      gains: gainsText(event.gains),
    });
    return;
  }
  if (event.event !== "trial") return;
  dashboard.tuneTrials.push(event);
  $("#tune-progress").value = event.trial;
  $("#tune-text").textContent =
    `${t("tune.trial", { n: event.trial })}: ${gainsText(event.gains)} · ${figureText(event)}`;
  if (event.times.length) addRun(event);
}

function readEnvelope() {
  const loop = "position";
  const goal = $("#tune-goal").value;
  return {
    id: Number($("#step-motor").value),
    loop,
    goal,
    travel: readNumber($("#tune-travel"), t("tune.travel"), { above: 0, max: 655 }),
    max_rpm: readNumber($("#tune-rpm"), t("tune.maxRpm"), { min: 1, max: 6553 }),
    max_current: readNumber($("#tune-current"), t("tune.maxCurrent"), { min: 0.1, max: 25.4 }),
    trials: readNumber($("#tune-trials"), t("tune.trials"), { min: 2, max: 60, integer: true }),
  };
}

function showResult(result) {
  const box = $("#tune-result");
  if (!result.chosen_gains) {
    box.textContent = t("tune.noneMeasured");
    box.dataset.chosen = "";
    return;
  }
  const start = result.start?.figures;
  const chosen = result.chosen?.figures;
  const fig = (f) =>
    f
      ? t("tune.trialFigures", {
          overshoot: num(f.overshoot, 1),
          settling: f.settling_time == null ? t("step.notSettled") : `${num(f.settling_time * 1000, 0)} ms`,
        })
      : "–";
  box.textContent = t("tune.result", {
    start: gainsText(result.start_gains),
    startFigures: fig(start),
    chosen: gainsText(result.chosen_gains),
    chosenFigures: fig(chosen),
  });
  if (result.unmet?.length) box.textContent += ` · ${t("tune.unmet", { list: result.unmet.join(", ") })}`;
  box.dataset.chosen = gainsText(result.chosen_gains);
}

async function runTune() {
  if (dashboard.mode !== "server") {
    say(t("tune.needsServer"), "error");
    return;
  }
  const args = readEnvelope();
  state.running = true;
  state.result = null;
  state.id = args.id;
  dashboard.tuneTrials = [];
  dashboard.tuneResult = null;
  dashboard.stepRuns = dashboard.stepRuns.filter((run) => !run.tune);
  emit("step-runs");
  $("#tune-run").disabled = true;
  $("#tune-cancel").disabled = false;
  $("#tune-apply").disabled = true;
  $("#tune-result").textContent = "";
  $("#tune-panel").dataset.state = "running";
  try {
    const result = await ask("tune", args);
    state.result = result;
    dashboard.tuneResult = result;
    if (result.cancelled) {
      $("#tune-text").textContent = t(result.restored ? "tune.cancelled" : "tune.cancelledNotRestored", {
        gains: gainsText(result.start_gains),
      });
      $("#tune-panel").dataset.state = "cancelled";
      return;
    }
    $("#tune-text").textContent = t("tune.done", { n: result.trials.length, gains: gainsText(result.start_gains) });
    showResult(result);
    const better = result.chosen_gains && gainsText(result.chosen_gains) !== gainsText(result.start_gains);
    $("#tune-apply").disabled = !better;
    $("#tune-panel").dataset.state = "done";
  } catch (error) {
    $("#tune-panel").dataset.state = "failed";
    throw error;
  } finally {
    state.running = false;
    $("#tune-run").disabled = false;
    $("#tune-cancel").disabled = true;
  }
}

async function cancelTune() {
  $("#tune-cancel").disabled = true;
  $("#tune-text").textContent = t("tune.cancelling");
  await ask("tune_cancel", {});
}

async function applyTune() {
  const result = state.result;
  if (!result?.chosen_gains) return;
  const id = state.id;
  $("#tune-apply").disabled = true;
  const done = [];
  for (const k of GAINS) {
    const name = `position-${k}`;
    const answer = await ask("set", { id, name, value: result.chosen_gains[k] });
    done.push(`${t(`setting.${name}`)} = ${answer.value}`);
    const input = $(`#gain-${k}`);
    if (input && Number($("#step-motor").value) === id) input.value = answer.value;
  }
  $("#tune-text").textContent = t("tune.applied", { id, list: done.join(", ") });
  $("#tune-panel").dataset.state = "applied";
}

export function startTune() {
  dashboard.tuneTrials = [];
  $("#tune-run").onclick = act(() => t("op.tune"), runTune);
  $("#tune-cancel").onclick = act(() => t("op.tune_cancel"), cancelTune);
  $("#tune-apply").onclick = act(() => t("tune.apply"), applyTune);
  $("#tune-cancel").disabled = true;
  $("#tune-apply").disabled = true;
  on("tune", onEvent);
}
