// The Motors view: discovery, and a card per motor with its state badge, bus statistics, live
// readings, a compact plot (position and target) and the motion controls.
import { $, $$, build, download } from "../core/dom.js";
import { num, onLanguage, t } from "../core/i18n.js";
import { InputProblem, readNumber } from "../core/input.js";
import { BAUD_RATES, BUSY_WINDOW_MS, DEVICE_LIMIT, MOVE_LIMIT, RPM_MAX, RPM_MIN } from "../core/limits.js";
import { motorState } from "../core/motorstate.js";
import { csv, lastOf, trim, windowStart } from "../core/series.js";
import { dashboard, emit, on } from "../core/store.js";
import { act, ask, say } from "./messages.js";
import { COLOURS, makePlot, setPlotData } from "./plots.js";

export const WINDOW_S = 10; // seconds of history in the live plots
const KEEP_S = 60; // seconds kept per motor (for pause, zoom and CSV export)
const now = () => performance.now() / 1000;

// ---- discovery ----------------------------------------------------------------------------
function fillRates() {
  const select = $("#discover-rates");
  const chosen = select.value;
  select.replaceChildren(
    build("option", { value: "all", textContent: t("motors.allRates", { n: BAUD_RATES.length }) }),
    ...BAUD_RATES.map((rate) => build("option", { value: rate, textContent: t("motors.rateOnly", { rate }) })),
  );
  if (chosen) select.value = chosen;
}

export async function runDiscovery(rates) {
  dashboard.everDiscovered = true;
  $("#discover").disabled = true;
  $("#discover-text").textContent = t("motors.scanning");
  try {
    const result = await ask("discover", rates ? { rates } : {});
    $("#discover-progress").value = $("#discover-progress").max;
    const list = result.motors.map((m) => t("motors.idAt", { id: m.id, rate: m.baudrate })).join(", ");
    $("#discover-text").textContent = t("motors.found", { n: result.motors.length, list: list || t("motors.none") });
    $("#discover-text").dataset.found = result.motors.map((m) => m.id).join(",");
    setMotors(result.known ?? result.motors);
    await ask("watch", { ids: [...dashboard.motors.keys()] });
    return result;
  } finally {
    $("#discover").disabled = false;
  }
}

export function showProgress(p) {
  dashboard.progressEvents = (dashboard.progressEvents ?? 0) + 1;
  $("#discover-progress").max = p.total;
  $("#discover-progress").value = p.index + 1;
  $("#discover-text").textContent = t(p.walking_id != null ? "motors.progressWalking" : "motors.progress", {
    rate: p.rate,
    index: p.index + 1,
    total: p.total,
    id: p.walking_id,
    found: p.found.join(", ") || t("motors.none"),
  });
  for (const info of p.motors ?? []) if (!dashboard.motors.has(info.id)) addMotor(info); // cards appear as found
}

// ---- the set of motors --------------------------------------------------------------------
export function setMotors(motors) {
  const wanted = new Set(motors.map((m) => m.id));
  for (const [id, motor] of dashboard.motors) {
    if (!wanted.has(id)) {
      motor.forget();
      motor.plot.destroy();
      motor.card.remove();
      dashboard.motors.delete(id);
    }
  }
  for (const info of motors) {
    const motor = dashboard.motors.get(info.id);
    if (motor) {
      motor.info = info;
      motor.subtitle.textContent = subtitle(info);
    } else addMotor(info);
  }
  emit("motors", [...dashboard.motors.keys()]);
}

function addMotor(info) {
  dashboard.motors.set(info.id, makeCard(info));
  const cards = [...dashboard.motors.values()].sort((a, b) => a.info.id - b.info.id).map((m) => m.card);
  $("#cards").replaceChildren(...cards);
  emit("motors", [...dashboard.motors.keys()]);
  if (dashboard.mode === "server") readControl(info.id);
}

/** What the badge needs to know first: is control on or off (read once; later known from commands). */
function readControl(id) {
  dashboard.link
    ?.request("read_settings", { id })
    .then((answer) => {
      const motor = dashboard.motors.get(id);
      if (motor && motor.control == null) motor.control = answer.settings.control === "off" ? "off" : "on";
    })
    .catch(() => {});
}

const subtitle = (info) =>
  t("motors.subtitle", { rate: info.baudrate, firmware: info.firmware ?? "?" }) +
  (info.line ? ` · ${t("motors.line", { line: t(`line.${info.line}`) })}` : "");

function makeCard(info) {
  const id = info.id;
  const card = build("div", { className: "card", id: `motor-${id}` });
  card.dataset.id = id;
  const readout = build("div", { className: "readout" });
  const unsubscribe = []; // language listeners of this card, ended when the card goes
  const field = (name, labelKey, unit, titleKey, params) => {
    const value = build("b", { className: name, textContent: "–" });
    const label = build("span", { className: "label" });
    const box = build("span", { className: `field field-${name}` }, label, " ", value, ` ${unit}`);
    const texts = () => {
      label.textContent = t(labelKey);
      if (titleKey) box.title = t(titleKey, params);
    };
    texts();
    unsubscribe.push(onLanguage(texts));
    readout.append(box);
    return value;
  };
  const motor = {
    info,
    series: { t: [], position: [], speed: [], current: [], device: [], target: [], uncertain: [] },
    target: null, // the last move's target on the continuous scale, drawn with the actual position
    dirty: false,
    paused: false,
    control: null, // "on" | "off" | null (not known yet)
    stopped: false, // an emergency stop turned it off and no command was given to it since
    busy: 0, // settings writes in progress for it
    errors: 0,
    lastSampleAt: null,
    lastErrorAt: null,
    rate: { count: 0, since: now(), perSecond: 0 },
    values: {
      position: field("position", "motors.position", "°", "motors.positionTitle"),
      device: field("device", "motors.device", "°", "motors.deviceTitle", { device: DEVICE_LIMIT, move: MOVE_LIMIT }),
      speed: field("speed", "motors.speed", "RPM"),
      current: field("current", "motors.current", "A"),
    },
    badge: build("span", { className: "state", role: "status" }),
    stats: build("small", { className: "busstats" }),
    subtitle: build("small", { textContent: subtitle(info) }),
    card,
  };
  const pause = build("button", { className: "small pause" });
  const csvButton = build("button", { className: "small csv" });
  const labels = () => {
    pause.textContent = t(motor.paused ? "plot.resume" : "plot.pause");
    csvButton.textContent = "CSV";
    csvButton.title = t("motors.csvTitle");
    motor.subtitle.textContent = subtitle(motor.info);
  };
  motor.pauseButton = pause;
  card.append(
    build("h2", {}, `ID ${id}`, motor.badge, motor.subtitle, build("span", { className: "spacer" }), pause, csvButton),
    motor.stats,
    readout,
  );
  const plotBox = build("div", { className: "plot" });
  card.append(plotBox);
  const plotSeries = () => [
    { label: t("signal.position"), unit: "°", stroke: COLOURS[0] },
    { label: t("signal.target"), unit: "°", stroke: "#6b7280", dash: [6, 4], width: 1.5 },
  ];
  const buildPlot = () => {
    motor.plot?.destroy();
    motor.plot = makePlot(plotBox, {
      series: plotSeries(),
      height: 170,
      xLabel: t("plot.secondsNow"),
      onZoom: () => setPaused(motor, true, true),
      onReset: () => setPaused(motor, false),
    });
    motor.dirty = true;
  };
  buildPlot();
  pause.onclick = () => setPaused(motor, !motor.paused);
  csvButton.onclick = () => download(`nurimc-motor-${id}.csv`, motorCsv(motor), "text/csv");

  const number = (value, attrs = {}) => build("input", { type: "number", value, step: "any", ...attrs });
  const target = number(90, { className: "to" });
  const moveRpm = number(60, { className: "move-rpm", min: RPM_MIN });
  const runRpm = number(30, { className: "run-rpm" });
  const by = build("input", { type: "checkbox", className: "by" });
  const byLabel = build("span");
  const text = () => build("span", { className: "label" });
  const [toText, atText, rpmText, runText, runRpmText] = [text(), text(), text(), text(), text()];
  const button = (cls, handler) => build("button", { className: cls, onclick: handler });
  const move = button(
    "move primary",
    act(
      () => t("motors.moveFailed", { id }),
      async () => {
        const degrees = readNumber(target, t("motors.to"), { min: -100000, max: 100000 });
        const rpm = readNumber(moveRpm, t("motors.moveRpm"), { above: 0, max: RPM_MAX });
        const device = lastOf(motor.series.device);
        const aim = by.checked && device != null ? device + degrees : degrees;
        if (Math.abs(aim) > MOVE_LIMIT) {
          throw new InputProblem(
            t("motors.outsideRange", {
              aim: num(aim, 2),
              limit: MOVE_LIMIT,
              device: device == null ? "?" : num(device, 2),
            }),
          );
        }
        await ask("move", { id, degrees, rpm, relative: by.checked });
        const offset = lastOf(motor.series.position) - (device ?? 0);
        motor.target = (by.checked ? (device ?? 0) + degrees : degrees) + (Number.isFinite(offset) ? offset : 0);
        motor.control = "on";
      },
    ),
  );
  const run = button(
    "run",
    act(
      () => t("motors.runFailed", { id }),
      async () => {
        const rpm = readNumber(runRpm, t("motors.runRpm"), { min: -RPM_MAX, max: RPM_MAX, nonzero: true });
        await ask("run", { id, rpm, ramp: 0.5 });
        motor.target = null;
        motor.control = "on";
      },
    ),
  );
  const release = button(
    "release",
    act(
      () => t("motors.releaseFailed", { id }),
      async () => {
        await ask("release", { id });
        motor.target = null;
        motor.control = "off";
      },
    ),
  );
  const hold = button(
    "hold",
    act(
      () => t("motors.holdFailed", { id }),
      async () => {
        await ask("hold", { id });
        motor.target = lastOf(motor.series.position);
        motor.control = "on";
      },
    ),
  );
  const zero = button(
    "zero",
    act(
      () => t("motors.zeroFailed", { id }),
      async () => {
        const answer = await ask("set_zero", { id });
        motor.target = null;
        say(t("motors.zeroDone", { id, device: num(answer.device_position, 2) }));
      },
    ),
  );
  card.append(
    build(
      "div",
      { className: "controls move-row" },
      toText,
      target,
      atText,
      moveRpm,
      rpmText,
      build("label", { className: "by-label" }, by, byLabel),
      move,
    ),
    build("div", { className: "controls" }, runText, runRpm, runRpmText, run, release, hold, zero),
  );
  const controlTexts = () => {
    labels();
    toText.textContent = t("motors.toLabel");
    atText.textContent = t("motors.atLabel");
    rpmText.textContent = "RPM";
    runText.textContent = t("motors.runAt");
    runRpmText.textContent = "RPM";
    byLabel.textContent = t("motors.by");
    by.title = t("motors.byTitle");
    target.title = t("motors.toTitle", { limit: MOVE_LIMIT });
    target.ariaLabel = t("motors.to");
    moveRpm.title = t("motors.moveRpmTitle");
    moveRpm.ariaLabel = t("motors.moveRpm");
    runRpm.title = t("motors.runRpmTitle");
    runRpm.ariaLabel = t("motors.runRpm");
    move.textContent = t("motors.move");
    run.textContent = t("motors.run");
    release.textContent = t("motors.release");
    hold.textContent = t("motors.hold");
    zero.textContent = t("motors.zero");
    zero.title = t("motors.zeroTitle");
    motor.shownState = null; // re-say the badge
  };
  controlTexts();
  unsubscribe.push(
    onLanguage(() => {
      controlTexts();
      buildPlot();
    }),
  );
  motor.forget = () => {
    for (const stop of unsubscribe) stop();
  };
  return motor;
}

export function setPaused(motor, paused, zoomed = false) {
  motor.paused = paused;
  motor.zoomed = zoomed;
  motor.pauseButton.textContent = t(paused ? "plot.resume" : "plot.pause");
  motor.card.dataset.paused = paused ? "yes" : "no";
  if (!paused) motor.dirty = true;
}

function motorCsv(motor) {
  const s = motor.series;
  return csv(
    ["t_s", "position_deg", "device_position_deg", "speed_rpm", "current_a", "target_deg", "position_uncertain"],
    s.t.map((time, i) => [time, s.position[i], s.device[i], s.speed[i], s.current[i], s.target[i], s.uncertain[i]]),
  );
}

// ---- live data ----------------------------------------------------------------------------
export function addSamples(rows) {
  dashboard.samplesReceived += rows.length;
  const at = now();
  for (const [id, serverT, position, speed, current, device, uncertain] of rows) {
    const motor = dashboard.motors.get(id);
    if (!motor) continue;
    const time = serverT + dashboard.clockOffset;
    if (motor.series.t.length && time <= lastOf(motor.series.t)) continue; // the time axis only moves forward
    const s = motor.series;
    s.t.push(time);
    s.position.push(position);
    s.speed.push(speed);
    s.current.push(current);
    s.device.push(device ?? position);
    s.uncertain.push(uncertain ? 1 : 0); // whole turns may be missing (a gap the speed could not decide)
    s.target.push(motor.target);
    trim(s, time, KEEP_S);
    motor.latest = time;
    motor.lastSampleAt = at;
    motor.rate.count += 1;
    motor.dirty = true;
  }
  emit("samples");
}

export function motorError(m) {
  const motor = dashboard.motors.get(m.id);
  dashboard.errors += 1;
  if (motor) {
    motor.errors += 1;
    if (m.kind !== "busy") motor.lastErrorAt = now();
  }
}

/** After an emergency stop: every motor it read back as off shows "stopped" until it gets a command. */
export function markStopped(control) {
  for (const [id, value] of Object.entries(control)) {
    const motor = dashboard.motors.get(Number(id));
    if (!motor) continue;
    motor.stopped = true;
    motor.control = value === "off" ? "off" : null;
    motor.stopVerified = value === "off";
    motor.target = null;
    motor.card.dataset.control = value === "off" ? "off" : "unknown";
  }
}
// a settings write keeps its motor "busy" from the request until one busy window after the
// reply (the EEPROM write starts when the command has gone out; spec/profiles.json busy window)
const writes = (op, id) =>
  op === "restore" ? [...dashboard.motors.values()] : op === "set" ? [dashboard.motors.get(id)].filter(Boolean) : [];
on("command", ({ op, id }) => {
  const motor = dashboard.motors.get(id);
  if (motor) motor.stopped = false;
  for (const m of writes(op, id)) m.busy += 1;
});
on("command-done", ({ op, id }) => {
  for (const m of writes(op, id))
    setTimeout(() => {
      m.busy = Math.max(0, m.busy - 1);
    }, BUSY_WINDOW_MS);
});

/** Readings per second over the last second of samples (page clock, seconds). */
export function readingsPerSecond(times) {
  const last = lastOf(times);
  if (last == null) return 0;
  let i = times.length - 1;
  while (i > 0 && times[i - 1] > last - 1) i--;
  const span = last - times[i];
  return span > 0 ? (times.length - 1 - i) / span : 0;
}

function refreshCard(motor, at) {
  const s = motor.series;
  const last = s.t.length - 1;
  motor.rate.perSecond = readingsPerSecond(s.t);
  const state = motorState(
    { ...motor, speed: last >= 0 ? s.speed[last] : null, portDown: dashboard.mode === "server" && dashboard.portDown },
    at,
  );
  if (state !== motor.shownState) {
    motor.shownState = state;
    motor.badge.textContent = t(`state.${state}`);
    motor.badge.className = `state state-${state}`;
    motor.card.dataset.state = state;
    motor.card.classList.toggle("stale", state === "silent"); // the readings shown are the last ones, not now
    motor.badge.title = state === "silent" ? t(dashboard.portDown ? "motors.staleTitlePort" : "motors.staleTitle") : "";
  }
  if (motor.control) motor.card.dataset.control = motor.control;
  const age = motor.lastSampleAt == null ? null : at - motor.lastSampleAt;
  motor.stats.textContent = t("motors.stats", {
    rate: num(state === "silent" ? 0 : motor.rate.perSecond, 0), // not the last second it answered in
    errors: motor.errors,
    age: age == null ? "–" : num(age * 1000, 0),
  });
  if (last < 0) return;
  const unsure = s.uncertain[last] === 1;
  motor.values.position.textContent = unsure ? `${num(s.position[last], 2)} ?` : num(s.position[last], 2);
  motor.values.position.title = unsure ? t("motors.positionUncertain") : t("motors.positionTitle");
  motor.card.dataset.positionUncertain = unsure ? "yes" : "no";
  motor.values.device.textContent = num(s.device[last], 2);
  motor.values.speed.textContent = num(s.speed[last], 1);
  motor.values.current.textContent = num(s.current[last], 1);
  motor.card.dataset.lastPosition = s.position[last];
  motor.card.dataset.devicePosition = s.device[last];
}

let lastCardRefresh = 0;
function redraw() {
  const at = now();
  const shown = !document.hidden && !$("#view-motors").classList.contains("hidden");
  const refresh = shown && at - lastCardRefresh > 0.1;
  if (refresh) lastCardRefresh = at;
  for (const motor of dashboard.motors.values()) {
    if (refresh || motor.dirty) refreshCard(motor, at);
    if (!motor.dirty || motor.paused || !shown) continue; // a hidden card's plot is drawn when it shows
    motor.dirty = false;
    const s = motor.series;
    if (!s.t.length) continue;
    const latest = lastOf(s.t);
    const from = windowStart(s.t, latest, WINDOW_S);
    setPlotData(motor.plot, [
      s.t.slice(from).map((time) => time - latest),
      s.position.slice(from),
      s.target.slice(from),
    ]);
  }
  emit("frame");
  requestAnimationFrame(redraw);
}

export function startMotors() {
  fillRates();
  onLanguage(() => {
    fillRates();
    for (const motor of dashboard.motors.values()) motor.shownState = null;
  });
  $("#discover").onclick = act(
    () => t("op.discover"),
    () => {
      const choice = $("#discover-rates").value;
      return runDiscovery(choice === "all" ? null : [Number(choice)]);
    },
  );
  requestAnimationFrame(redraw);
}
export { $$ };
