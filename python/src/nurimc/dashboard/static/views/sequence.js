// The Sequences view: steps run one after another; saved and loaded as JSON; ended by the E-STOP.
import { $, build, download } from "../core/dom.js";
import { onLanguage, serverError, t } from "../core/i18n.js";
import { InputProblem, looksNumeric, readNumber } from "../core/input.js";
import { MAX_ID, MOVE_LIMIT, RPM_MAX } from "../core/limits.js";
import { dashboard, on } from "../core/store.js";
import { act, ask } from "./messages.js";

const STEP_FIELDS = {
  move: [
    ["id", 1],
    ["degrees", 90],
    ["rpm", 60],
  ],
  wait: [["seconds", 1]],
  set: [
    ["id", 1],
    ["name", "position-kp"],
    ["value", 50],
  ],
  release: [["id", 1]],
};
let sequenceRun = null;
let statusKey = null;

function setSeqStatus(state, key, params = {}) {
  statusKey = [state, key, params];
  const status = $("#seq-status");
  status.dataset.state = state;
  status.textContent = key ? t(key, params) : "";
}

function addStep(kind, values = {}) {
  const step = { kind, values: {} };
  for (const [key, fallback] of STEP_FIELDS[kind]) step.values[key] = values[key] ?? fallback;
  dashboard.sequence.push(step);
  render();
}

function render() {
  const items = dashboard.sequence.map((step, index) => {
    const inputs = STEP_FIELDS[step.kind].map(([key]) => {
      const isText = key === "name" || (key === "value" && typeof step.values[key] === "string");
      const input = build("input", {
        type: isText ? "text" : "number",
        step: "any",
        value: step.values[key] ?? "",
        ariaLabel: t(`seq.field.${key}`),
      });
      input.dataset.key = key;
      input.oninput = () => {
        step.values[key] = input.value;
      };
      return build("label", {}, `${t(`seq.field.${key}`)} `, input);
    });
    const remove = build("button", { textContent: "✕", title: t("seq.remove"), className: "small" });
    remove.onclick = () => {
      dashboard.sequence.splice(index, 1);
      render();
    };
    const up = build("button", { textContent: "↑", title: t("seq.up"), className: "small", disabled: index === 0 });
    up.onclick = () => {
      dashboard.sequence.splice(index - 1, 0, dashboard.sequence.splice(index, 1)[0]);
      render();
    };
    return build(
      "li",
      { className: "seq-step" },
      build("b", { textContent: t(`seq.kind.${step.kind}`) }),
      ...inputs,
      up,
      remove,
    );
  });
  $("#seq-list").replaceChildren(...items);
}

/** A step checked the way the fields are: a blank or invalid field stops the run before it starts. */
function checkedStep(step, index) {
  const field = (key) => $("#seq-list").children[index].querySelector(`[data-key="${key}"]`);
  const where = t("seq.where", { n: index + 1, kind: t(`seq.kind.${step.kind}`) });
  const n = (key, opts) => readNumber(field(key), `${where} ${t(`seq.field.${key}`)}`, opts);
  const id = () => n("id", { min: 0, max: MAX_ID, integer: true });
  switch (step.kind) {
    case "move":
      return {
        op: "move",
        args: {
          id: id(),
          degrees: n("degrees", { min: -MOVE_LIMIT, max: MOVE_LIMIT }),
          rpm: n("rpm", { above: 0, max: RPM_MAX }),
        },
      };
    case "wait":
      return { wait: n("seconds", { min: 0, max: 3600 }) };
    case "release":
      return { op: "release", args: { id: id() } };
    case "set": {
      const name = field("name").value.trim();
      const raw = field("value").value.trim();
      if (!name || !raw) throw new InputProblem(`${where}: ${t("seq.needNameValue")}`);
      return { op: "set", args: { id: id(), name, value: looksNumeric(raw) ? Number(raw) : raw } };
    }
  }
  throw new InputProblem(`${where}: ${t("seq.unknownKind")}`);
}

function stopSequence(why) {
  if (!sequenceRun) return;
  sequenceRun.stopped = why;
  sequenceRun.wake?.();
}

async function runSequence() {
  if (sequenceRun) throw new InputProblem(t("seq.alreadyRunning"));
  const steps = dashboard.sequence.map(checkedStep);
  if (!steps.length) throw new InputProblem(t("seq.addFirst"));
  const run = { stopped: null, stops: dashboard.stops };
  sequenceRun = run;
  setSeqStatus("running", null);
  try {
    for (const [index, step] of steps.entries()) {
      if (run.stopped || dashboard.stops !== run.stops) break;
      setSeqStatus("running", "seq.running", { n: index + 1, total: steps.length });
      if (step.wait != null) {
        await new Promise((resolve) => {
          const timer = setTimeout(resolve, step.wait * 1000);
          run.wake = () => {
            clearTimeout(timer);
            resolve();
          };
        });
      } else await ask(step.op, step.args);
    }
    const stopped = run.stopped || (dashboard.stops !== run.stops ? "estop" : null);
    if (stopped) setSeqStatus("stopped", stopped === "estop" ? "seq.stoppedEstop" : "seq.stoppedYou");
    else setSeqStatus("done", "seq.done", { n: steps.length });
  } catch (error) {
    setSeqStatus("failed", "seq.failed", { why: serverError(error.message).text });
    throw error;
  } finally {
    sequenceRun = null;
  }
}

function loadSequence(document_) {
  if (document_?.format !== "nurimc-sequence/1" || !Array.isArray(document_.steps))
    throw new InputProblem(t("seq.notSequence"));
  const steps = document_.steps.map((s, i) => {
    if (!STEP_FIELDS[s?.kind]) throw new InputProblem(t("seq.badKind", { n: i + 1, kind: JSON.stringify(s?.kind) }));
    return s;
  });
  dashboard.sequence = [];
  for (const { kind, ...values } of steps) addStep(kind, values);
}

export function startSequence() {
  dashboard.loadSequence = loadSequence;
  const idNow = () => Number($("#setup-motor").value) || 1;
  $("#seq-run").onclick = act(() => t("op.sequence"), runSequence);
  $("#seq-stop").onclick = () => stopSequence("you");
  $("#seq-add-move").onclick = () => addStep("move", { id: idNow() });
  $("#seq-add-wait").onclick = () => addStep("wait");
  $("#seq-add-set").onclick = () => addStep("set", { id: idNow() });
  $("#seq-add-release").onclick = () => addStep("release", { id: idNow() });
  $("#seq-save").onclick = () =>
    download(
      "nurimc-sequence.json",
      JSON.stringify(
        { format: "nurimc-sequence/1", steps: dashboard.sequence.map((s) => ({ kind: s.kind, ...s.values })) },
        null,
        2,
      ),
      "application/json",
    );
  $("#seq-load").onchange = act(
    () => t("op.loadSequence"),
    async (event) => {
      const file = event.target.files[0];
      if (!file) return;
      let document_;
      try {
        document_ = JSON.parse(await file.text());
      } catch (error) {
        throw new InputProblem(t("msg.notJson", { name: file.name, why: error.message }));
      }
      loadSequence(document_);
      event.target.value = "";
    },
  );
  on("estop-pressed", () => stopSequence("estop"));
  onLanguage(() => {
    render();
    if (statusKey) setSeqStatus(...statusKey);
  });
}
