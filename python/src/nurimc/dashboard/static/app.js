// The console page: picks its mode (server or direct Web Serial), then wires the views.
import uPlot from "./vendor/uplot/uPlot.esm.js";
import { ServerLink } from "./server-link.js";
import { DirectLink } from "./direct-link.js";

const WINDOW_S = 10; // seconds of history in the live plots
const RAW_ROWS = 500; // rows shown in the raw view (all are kept for export)
const BAUD_RATES = [110, 300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200, 230400, 250000, 500000, 1000000];

const $ = (selector) => document.querySelector(selector);
function build(tag, props = {}, ...children) {
  const node = Object.assign(document.createElement(tag), props);
  for (const child of children) node.append(child);
  return node;
}

// Everything the page knows, readable by tests and people alike (window.dashboard).
const dashboard = {
  mode: null,
  link: null,
  motors: new Map(), // id -> { info, series: {t, position, speed, current}, plot, card, dirty }
  samplesReceived: 0,
  frames: [],
  settings: [],
  lastStep: null,
};
window.dashboard = dashboard;

function say(text, kind = "info") {
  const box = build("div", { className: `message ${kind}`, textContent: text });
  $("#messages").append(box);
  setTimeout(() => box.remove(), kind === "error" ? 12000 : 5000);
}

async function ask(op, args) {
  try {
    return await dashboard.link.request(op, args);
  } catch (error) {
    say(`${op}: ${error.message}`, "error");
    throw error;
  }
}

// ---- mode ---------------------------------------------------------------------------------
async function start() {
  let info = null;
  try {
    const response = await fetch("./api/info", { cache: "no-store" });
    if (response.ok) info = await response.json();
  } catch {
    info = null;
  }
  if (info && info.server === "nurimc-dashboard") {
    dashboard.mode = "server";
    dashboard.settings = info.settings;
    $("#mode").textContent = info.sim ? "server · simulated bus" : "server";
    const link = new ServerLink(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
    await link.connect();
    link.on("closed", (m) => setStatus(`disconnected from the server${m.reason ? `: ${m.reason}` : ""}; reload the page`));
    useLink(link);
    setStatus("connected");
  } else {
    await startDirect();
  }
}

async function startDirect() {
  dashboard.mode = "direct";
  $("#mode").textContent = "direct · Web Serial";
  const button = $("#connect");
  const rates = $("#direct-baud");
  for (const rate of BAUD_RATES) rates.append(build("option", { value: rate, textContent: `${rate} bps`, selected: rate === 115200 }));
  button.classList.remove("hidden");
  rates.classList.remove("hidden");
  try {
    dashboard.lib = await import("./nurimc.browser.js");
  } catch {
    setStatus("direct mode needs nurimc.browser.js next to this page (see docs/dashboard.md)");
    button.disabled = true;
    return;
  }
  if (!("serial" in navigator)) {
    setStatus("this browser has no Web Serial: use Chrome or Edge on https:// or http://localhost, or run `nurimc dashboard`");
    button.disabled = true;
    return;
  }
  setStatus("no server: connect a serial port to drive the bus from this page");
  button.onclick = async () => {
    try {
      const link = await new DirectLink(dashboard.lib, Number(rates.value)).connect();
      useLink(link);
      setStatus(`connected at ${rates.value} bps`);
    } catch (error) {
      say(`connect: ${error.message}`, "error");
    }
  };
}

function setStatus(text) {
  $("#status").textContent = text;
}

function useLink(link) {
  dashboard.link = link;
  link.on("samples", (m) => addSamples(m.rows));
  link.on("progress", showProgress);
  link.on("frames", (m) => addFrames(m.frames));
  link.on("estop", showEstop);
  link.on("motor_error", (m) => say(`ID ${m.id}: ${m.message}`, "error"));
  fillSettingsTable();
}

// ---- discovery ----------------------------------------------------------------------------
for (const rate of BAUD_RATES) $("#discover-rates").append(build("option", { value: rate, textContent: `${rate} only` }));

$("#discover").onclick = async () => {
  if (!dashboard.link) return say("connect first", "error");
  const choice = $("#discover-rates").value;
  $("#discover").disabled = true;
  $("#discover-text").textContent = "scanning…";
  try {
    const result = await ask("discover", choice === "all" ? {} : { rates: [Number(choice)] });
    $("#discover-progress").value = $("#discover-progress").max;
    $("#discover-text").textContent = `found ${result.motors.length} motor(s): ${result.motors.map((m) => `ID ${m.id} @ ${m.baudrate}`).join(", ") || "none"}`;
    $("#discover-text").dataset.found = result.motors.map((m) => m.id).join(",");
    setMotors(result.motors);
    await ask("watch", { ids: result.motors.map((m) => m.id) });
  } finally {
    $("#discover").disabled = false;
  }
};

function showProgress(p) {
  dashboard.progressEvents = (dashboard.progressEvents ?? 0) + 1;
  $("#discover-progress").max = p.total;
  $("#discover-progress").value = p.index + 1;
  const walking = p.walking_id != null ? `, pinging ID ${p.walking_id}` : "";
  $("#discover-text").textContent = `${p.rate} bps (${p.index + 1}/${p.total})${walking}; found so far: ${p.found.join(", ") || "none"}`;
}

// ---- motor cards and live plots -----------------------------------------------------------
function setMotors(motors) {
  $("#cards").replaceChildren();
  dashboard.motors.clear();
  for (const info of motors) dashboard.motors.set(info.id, makeCard(info));
  for (const select of document.querySelectorAll(".motor-select")) {
    select.replaceChildren(...motors.map((m) => build("option", { value: m.id, textContent: `ID ${m.id}` })));
  }
}

function makeCard(info) {
  const card = build("div", { className: "card", id: `motor-${info.id}` });
  card.dataset.id = info.id;
  const readout = build("div", { className: "readout" });
  const field = (name, unit) => {
    const value = build("b", { className: name, textContent: "–" });
    readout.append(build("span", {}, `${name} `, value, ` ${unit}`));
    return value;
  };
  const motor = {
    info,
    series: { t: [], position: [], speed: [], current: [] },
    dirty: false,
    values: { position: field("position", "°"), speed: field("speed", "RPM"), current: field("current", "A") },
    badge: build("span", { className: "control-state" }),
    card,
  };
  card.append(build("h2", {}, `ID ${info.id}`, build("small", { textContent: `${info.baudrate} bps · firmware ${info.firmware ?? "?"}` }), motor.badge), readout);
  const plotBox = build("div", { className: "plot" });
  card.append(plotBox);
  motor.plot = new uPlot(
    {
      width: 490,
      height: 200,
      legend: { live: false },
      scales: { x: { time: false }, deg: {}, rpm: {}, amp: {} },
      series: [
        { label: "t (s)" },
        { label: "position °", scale: "deg", stroke: "#2457c5", width: 1.5 },
        { label: "speed RPM", scale: "rpm", stroke: "#d97706", width: 1 },
        { label: "current A", scale: "amp", stroke: "#059669", width: 1 },
      ],
      axes: [{}, { scale: "deg", label: "°" }, { scale: "rpm", side: 1, label: "RPM", grid: { show: false } }],
    },
    [[], [], [], []],
    plotBox,
  );
  const num = (value, title) => build("input", { type: "number", value, step: "any", title });
  const target = num(90, "degrees"), moveRpm = num(60, "RPM"), runRpm = num(30, "RPM (negative: clockwise)");
  const by = build("input", { type: "checkbox", title: "move by this amount from where the motor is" });
  const button = (text, handler) => build("button", { textContent: text, onclick: handler });
  const id = info.id;
  card.append(
    build("div", { className: "controls" }, "to ", target, "° at ", moveRpm, " RPM ", build("label", {}, by, " by"),
      button("Move", () => ask("move", { id, degrees: Number(target.value), rpm: Number(moveRpm.value), relative: by.checked }).then(() => setControl(motor, "on")))),
    build("div", { className: "controls" }, "run at ", runRpm, " RPM ",
      button("Run", () => ask("run", { id, rpm: Number(runRpm.value), ramp: 0.5 }).then(() => setControl(motor, "on"))),
      button("Release", () => ask("release", { id }).then(() => setControl(motor, "off"))),
      button("Hold", () => ask("hold", { id }).then(() => setControl(motor, "on")))),
  );
  $("#cards").append(card);
  return motor;
}

function setControl(motor, control) {
  motor.badge.textContent = control === "off" ? "released" : "";
  motor.badge.className = `control-state ${control === "off" ? "released" : ""}`;
  motor.card.dataset.control = control;
}

function addSamples(rows) {
  dashboard.samplesReceived += rows.length;
  for (const [id, t, position, speed, current] of rows) {
    const motor = dashboard.motors.get(id);
    if (!motor) continue;
    const s = motor.series;
    s.t.push(t); s.position.push(position); s.speed.push(speed); s.current.push(current);
    while (s.t.length && s.t[0] < t - WINDOW_S) { s.t.shift(); s.position.shift(); s.speed.shift(); s.current.shift(); }
    motor.dirty = true;
  }
}

function redraw() {
  for (const motor of dashboard.motors.values()) {
    if (!motor.dirty) continue;
    motor.dirty = false;
    const s = motor.series;
    motor.plot.setData([s.t, s.position, s.speed, s.current]);
    const last = s.t.length - 1;
    motor.values.position.textContent = s.position[last].toFixed(2);
    motor.values.speed.textContent = s.speed[last].toFixed(1);
    motor.values.current.textContent = s.current[last].toFixed(1);
    motor.card.dataset.lastPosition = s.position[last];
  }
  requestAnimationFrame(redraw);
}
requestAnimationFrame(redraw);

// ---- emergency stop -----------------------------------------------------------------------
$("#estop").onclick = async () => {
  if (!dashboard.link) return say("not connected: switch the motors' power off", "error");
  await ask("estop");
};

function showEstop(m) {
  const entries = Object.entries(m.control);
  for (const [id, control] of entries) {
    const motor = dashboard.motors.get(Number(id));
    if (motor) setControl(motor, control === "off" ? "off" : "unknown");
  }
  const bad = entries.filter(([, control]) => control !== "off");
  say(bad.length
    ? `EMERGENCY STOP sent at ${m.rates.join(", ")} bps, but not confirmed for ${bad.map(([id, c]) => `ID ${id} (${c})`).join(", ")}: cut the power`
    : `EMERGENCY STOP: control off sent at ${m.rates.join(", ")} bps; ${entries.length} motor(s) confirmed released`, bad.length ? "error" : "info");
  $("#estop").dataset.lastResult = JSON.stringify(m.control);
}

// ---- settings editor ----------------------------------------------------------------------
function fillSettingsTable() {
  const body = $("#settings-table tbody");
  body.replaceChildren();
  for (const s of dashboard.settings) {
    const input = s.choices.length
      ? build("select", {}, ...s.choices.map((c) => build("option", { value: c, textContent: c })))
      : build("input", { type: "number", min: s.min, max: s.max, step: s.step, title: s.range });
    input.disabled = !s.writable;
    input.oninput = () => { input.dataset.edited = "yes"; }; // a read-back must not overwrite what the user types
    const result = build("td", { className: "result" });
    const write = build("button", { textContent: "Write", disabled: !s.writable });
    const row = build("tr", { id: `setting-${s.name}` },
      build("td", { textContent: s.name, title: s.doc }), build("td", { className: "value" }), build("td", {}, input),
      build("td", { textContent: `${s.range}` }), build("td", {}, write), result);
    write.onclick = async () => {
      const id = Number($("#settings-motor").value);
      const raw = input.value.trim();
      if (raw === "") return say(`${s.name}: give a value (${s.range})`, "error");
      const value = s.choices.length ? raw : Number(raw);
      result.textContent = "writing…";
      result.className = "result";
      try {
        const answer = await ask("set", { id, name: s.name, value });
        row.querySelector(".value").textContent = answer.value;
        result.textContent = `written and verified: ${answer.value}`;
        delete input.dataset.edited;
        result.className = "result ok";
      } catch (error) {
        result.textContent = error.message;
        result.className = "result bad";
      }
    };
    body.append(row);
  }
}

async function readSettings() {
  const id = Number($("#settings-motor").value);
  const answer = await ask("read_settings", { id });
  for (const [name, value] of Object.entries(answer.settings)) {
    const row = document.getElementById(`setting-${name}`);
    if (!row) continue;
    row.querySelector(".value").textContent = value;
    const input = row.querySelector("input, select");
    if (input && !input.disabled && !input.dataset.edited) input.value = value;
  }
  dashboard.settingsShownFor = id;
  return answer.settings;
}
$("#settings-read").onclick = readSettings;
$("#settings-motor").onchange = () => {
  for (const input of document.querySelectorAll("#settings-table [data-edited]")) delete input.dataset.edited;
  readSettings().catch(() => {});
};

// ---- step response ------------------------------------------------------------------------
let stepPlot = null;
$("#step-run").onclick = async () => {
  const id = Number($("#step-motor").value);
  $("#step-run").disabled = true;
  $("#step-figures").textContent = "stepping…";
  try {
    const r = await ask("step", { id, amplitude: Number($("#step-amplitude").value), rpm: Number($("#step-rpm").value), duration: Number($("#step-duration").value) });
    dashboard.lastStep = r;
    const data = [r.times, r.times.map(() => r.target), r.positions];
    stepPlot?.destroy();
    stepPlot = new uPlot({ width: 900, height: 320, scales: { x: { time: false } },
      series: [{ label: "t (s)" }, { label: "target °", stroke: "#9ca3af", dash: [6, 4] }, { label: "actual °", stroke: "#2457c5", width: 2 }] }, data, $("#step-plot"));
    const rise = r.rise_time == null ? "not reached" : `${(r.rise_time * 1000).toFixed(0)} ms`;
    $("#step-figures").textContent = `rise time (10–90 %): ${rise} · overshoot: ${r.overshoot.toFixed(1)} % · final error: ${r.final_error} ° · ${r.settled ? "settled" : "not settled"}`;
  } catch {
    $("#step-figures").textContent = "";
  } finally {
    $("#step-run").disabled = false;
  }
};

$("#gains-write").onclick = async () => {
  const id = Number($("#step-motor").value);
  const gains = { "position-kp": $("#gain-kp").value, "position-ki": $("#gain-ki").value, "position-kd": $("#gain-kd").value };
  for (const [name, value] of Object.entries(gains)) {
    if (value === "") continue;
    const answer = await ask("set", { id, name, value: Number(value) });
    $("#gains-text").textContent = `${name} = ${answer.value} (verified)`;
  }
};

// ---- backup / restore ---------------------------------------------------------------------
$("#backup").onclick = async () => {
  const ids = [...dashboard.motors.keys()];
  if (!ids.length) return say("discover motors first", "error");
  const document_ = await ask("backup", { ids });
  const text = JSON.stringify(document_, null, 2);
  $("#backup-text").textContent = text;
  download(`nurimc-backup-${document_.time}.json`, text, "application/json");
};

$("#restore-file").onchange = async (event) => {
  const file = event.target.files[0];
  if (!file) return;
  let document_;
  try {
    document_ = JSON.parse(await file.text());
  } catch (error) {
    return say(`restore: ${file.name} is not JSON (${error.message})`, "error");
  }
  const result = await ask("restore", { document: document_ });
  $("#backup-text").textContent = result.changed.length ? `restored (each verified):\n${result.changed.join("\n")}` : "nothing to change: every setting already matches";
};

function download(name, text, type) {
  const link = build("a", { href: URL.createObjectURL(new Blob([text], { type })), download: name });
  link.click();
  setTimeout(() => URL.revokeObjectURL(link.href), 1000);
}

// ---- raw frames ---------------------------------------------------------------------------
$("#raw-on").onchange = async (event) => {
  const result = await ask("frames", { on: event.target.checked });
  if (event.target.checked) { dashboard.frames = result.recent; renderFrames(); }
};
$("#raw-filter").oninput = () => renderFrames();
$("#raw-export").onclick = () => download("nurimc-frames.jsonl", filteredFrames().map((f) => JSON.stringify(f)).join("\n") + "\n", "application/x-ndjson");

function addFrames(frames) {
  dashboard.frames.push(...frames);
  if (dashboard.frames.length > 20000) dashboard.frames.splice(0, dashboard.frames.length - 20000);
  rawDirty = true;
}
let rawDirty = false;
setInterval(() => { if (rawDirty) { rawDirty = false; renderFrames(); } }, 250);

function filteredFrames() {
  const terms = $("#raw-filter").value.toLowerCase().split(/[\s,]+/).filter(Boolean);
  return dashboard.frames.filter((f) => terms.every((term) => {
    if (term.startsWith("id=")) return String(f.id) === term.slice(3);
    return f.dir === term || (f.name ?? "").includes(term) || f.hex.includes(term);
  }));
}

function renderFrames() {
  const frames = filteredFrames();
  $("#raw-count").textContent = `${frames.length} of ${dashboard.frames.length} frames`;
  const rows = frames.slice(-RAW_ROWS).reverse().map((f) => build("tr", {},
    build("td", { textContent: f.t.toFixed(4) }), build("td", { textContent: f.dir }), build("td", { textContent: f.id ?? "" }),
    build("td", { textContent: f.name }), build("td", { textContent: JSON.stringify(f.fields) }), build("td", { textContent: f.hex })));
  $("#raw-table tbody").replaceChildren(...rows);
}

// ---- views --------------------------------------------------------------------------------
for (const button of document.querySelectorAll("nav button")) {
  button.onclick = () => {
    for (const other of document.querySelectorAll("nav button")) other.classList.toggle("active", other === button);
    for (const view of document.querySelectorAll(".view")) view.classList.toggle("hidden", view.id !== `view-${button.dataset.view}`);
    if (button.dataset.view === "settings" && dashboard.motors.size) readSettings().catch(() => {});
  };
}

start().catch((error) => setStatus(`start failed: ${error.message}`));
