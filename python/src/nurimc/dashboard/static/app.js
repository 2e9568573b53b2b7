// The console page: picks its mode (server or direct Web Serial), then wires the views.

import { DirectLink } from "./direct-link.js";
import { ServerLink } from "./server-link.js";
import uPlot from "./vendor/uplot/uPlot.esm.js";

const WINDOW_S = 10; // seconds of history in the live plots
const KEEP_S = 60; // seconds kept per motor (for pause, zoom and CSV export)
const RAW_ROWS = 500; // rows shown in the raw view (all are kept for export)
const MAX_TOASTS = 4;
const ESTOP_RECEIPT_MS = 1000; // the server confirms it got the stop at once; no receipt by then is an alarm
const DEVICE_LIMIT = 655.35; // the device reports positions within ±655.35°; commands reach ±655.33°
const MOVE_LIMIT = 655.33;
// The controllers' 18 rates (spec/protocol.json); the one list on this page.
const BAUD_RATES = [
  110, 300, 600, 1200, 2400, 4800, 9600, 14400, 19200, 28800, 38400, 57600, 76800, 115200, 230400, 250000, 500000,
  1000000,
];
const COLOURS = ["#2457c5", "#d97706", "#059669", "#7c3aed", "#db2777", "#0891b2", "#65a30d", "#b91c1c"];

const $ = (selector) => document.querySelector(selector);
function build(tag, props = {}, ...children) {
  const node = Object.assign(document.createElement(tag), props);
  for (const child of children) if (child != null) node.append(child);
  return node;
}

// Everything the page knows, readable by tests and people alike (window.dashboard).
const dashboard = {
  mode: null,
  link: null,
  connected: false,
  motors: new Map(), // id -> { info, series, plot, card, dirty, paused, ... }
  samplesReceived: 0,
  frames: [],
  settings: [],
  lastStep: null,
  stepRuns: [],
  stops: 0, // emergency stops seen by this page: a running sequence ends when this changes
  everDiscovered: false,
  boot: null, // the server process the page last talked to (another one: restarted, new clock)
  clockOffset: 0, // server sample time + this = seconds on this page's clock, continuous across restarts
  sequence: [],
};
window.dashboard = dashboard;

// ---- messages -----------------------------------------------------------------------------
function say(text, kind = "info") {
  const box = $("#messages");
  const same = [...box.children].find((t) => t.dataset.text === text);
  if (same) {
    // the same message again: count it instead of stacking another
    same.dataset.count = Number(same.dataset.count ?? 1) + 1;
    same.querySelector(".count").textContent = `×${same.dataset.count}`;
    box.append(same);
    return same;
  }
  const close = build("button", { className: "close", textContent: "×", title: "close", ariaLabel: "close message" });
  const toast = build(
    "div",
    { className: `message ${kind}` },
    build("span", { className: "text", textContent: text }),
    build("span", { className: "count" }),
    close,
  );
  toast.dataset.text = text;
  close.onclick = () => toast.remove();
  box.append(toast);
  while (box.children.length > MAX_TOASTS) box.firstElementChild.remove();
  setTimeout(() => toast.remove(), kind === "error" ? 15000 : 6000);
  return toast;
}

/** A click handler that reports its failure instead of leaving an unhandled rejection. */
function act(what, fn) {
  return async (event) => {
    try {
      await fn(event);
    } catch (error) {
      if (!error.reported) say(`${what}: ${error.message}`, "error");
    }
  };
}

async function ask(op, args) {
  if (!dashboard.link) throw Object.assign(new Error("not connected"), { reported: false });
  try {
    return await dashboard.link.request(op, args);
  } catch (error) {
    say(`${op}: ${error.message}`, "error");
    error.reported = true;
    throw error;
  }
}

// ---- strict input: an empty or invalid field is an error, never a value --------------------
class InputProblem extends Error {}
function readNumber(
  input,
  label,
  { min = -Infinity, max = Infinity, integer = false, above = null, nonzero = false } = {},
) {
  const raw = input.value.trim();
  const fail = (why) => {
    input.setAttribute("aria-invalid", "true");
    input.focus();
    throw new InputProblem(`${label}: ${why}`);
  };
  if (input.validity?.badInput) fail("not a number");
  if (raw === "") fail("empty; give a number");
  if (!/^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(raw)) fail(`"${raw}" is not a number`);
  const value = Number(raw);
  if (!Number.isFinite(value)) fail(`${raw} is not a finite number`);
  if (integer && !Number.isInteger(value)) fail(`${raw} is not a whole number`);
  if (above != null && !(value > above)) fail(`${raw} must be above ${above}`);
  if (nonzero && value === 0) fail("must not be 0");
  if (value < min || value > max) fail(`${raw} is out of range ${min}..${max}`);
  input.removeAttribute("aria-invalid");
  return value;
}
document.addEventListener("input", (event) => event.target.removeAttribute?.("aria-invalid"));

// ---- mode and connection ------------------------------------------------------------------
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
    fillSettingsTable();
    setConnected(false, "connecting…");
    const link = new ServerLink(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
    useLink(link);
    link.on("open", onHello);
    link.on("closed", (m) => {
      dashboard.lostReason = m.reason ?? "";
      setConnected(false);
    });
    link.on("retrying", showRetry);
    link.start();
  } else {
    await startDirect();
  }
}

function setConnected(connected, detail = "") {
  dashboard.connected = connected;
  $("#controls").disabled = !connected;
  document.body.classList.toggle("offline", !connected);
  $("#banner").classList.toggle("hidden", connected);
  $("#estop").classList.toggle("unreachable", !connected);
  if (connected) {
    setStatus("connected");
  } else {
    setStatus("not connected");
    $("#banner-text").textContent = "Server unreachable: controls are off until it is back.";
    if (detail) $("#banner-detail").textContent = detail;
  }
}

function showRetry({ delay }) {
  dashboard.retryDelays = [...(dashboard.retryDelays ?? []), delay];
  const why = dashboard.lostReason ? ` (${dashboard.lostReason})` : "";
  $("#banner-detail").textContent =
    `Reconnecting in ${(delay / 1000).toFixed(1)} s${why}… If a motor is moving, cut its power.`;
}

async function onHello(hello) {
  if (hello.boot !== dashboard.boot) {
    // a new server process: its samples restart from 0; shift them so the plots carry on from where they were
    dashboard.boot = hello.boot;
    dashboard.clockOffset = performance.now() / 1000 - (hello.clock ?? 0);
  }
  setConnected(true);
  $("#bus-text").textContent = `${hello.port || "?"} at ${hello.baudrate} bps`;
  const known = hello.motors ?? [];
  const mine = [...dashboard.motors.values()].map((m) => m.info);
  if (known.length) {
    setMotors(known);
    await ask("watch", { ids: known.map((m) => m.id) }).catch(() => {});
  } else if (mine.length) {
    // the server restarted and forgot them: look again at the rates they were at
    say("the server was restarted: finding the motors again", "info");
    await runDiscovery([...new Set(mine.map((m) => m.baudrate))]).catch(() => {});
  } else if (!dashboard.everDiscovered) {
    await runDiscovery(null).catch(() => {});
  }
}

async function startDirect() {
  dashboard.mode = "direct";
  $("#mode").textContent = "direct · Web Serial";
  const button = $("#connect");
  const rates = $("#direct-baud");
  for (const rate of BAUD_RATES)
    rates.append(build("option", { value: rate, textContent: `${rate} bps`, selected: rate === 115200 }));
  button.classList.remove("hidden");
  rates.classList.remove("hidden");
  setConnected(false, "direct mode: connect a serial port");
  $("#banner-text").textContent = "Not connected.";
  $("#reconnect").classList.add("hidden");
  try {
    dashboard.lib = await import("./nurimc.browser.js");
  } catch {
    setStatus("direct mode needs nurimc.browser.js next to this page (see docs/dashboard.md)");
    button.disabled = true;
    return;
  }
  if (!("serial" in navigator)) {
    setStatus(
      "this browser has no Web Serial: use Chrome or Edge on https:// or http://localhost, or run `nurimc dashboard`",
    );
    button.disabled = true;
    return;
  }
  setStatus("no server: connect a serial port to drive the bus from this page");
  button.onclick = act("connect", async () => {
    const link = await new DirectLink(dashboard.lib, Number(rates.value)).connect();
    useLink(link);
    setConnected(true);
    setStatus(`connected at ${rates.value} bps`);
  });
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
  link.on("estop_received", () => {
    if ($("#estop").dataset.lastResult === "sending") $("#estop").dataset.lastResult = "received";
  });
  link.on("motors", (m) => setMotors(m.motors));
  link.on("motor_error", (m) =>
    say(m.kind === "busy" ? m.message : `ID ${m.id}: ${m.message}`, m.kind === "busy" ? "info" : "error"),
  );
}
$("#reconnect").onclick = () => dashboard.link?.retryNow?.();

// ---- discovery ----------------------------------------------------------------------------
for (const rate of BAUD_RATES)
  $("#discover-rates").append(build("option", { value: rate, textContent: `${rate} only` }));
for (const select of document.querySelectorAll(".baud-select")) {
  for (const rate of BAUD_RATES)
    select.append(build("option", { value: rate, textContent: `${rate} bps`, selected: rate === 115200 }));
}

async function runDiscovery(rates) {
  dashboard.everDiscovered = true;
  $("#discover").disabled = true;
  $("#discover-text").textContent = "scanning…";
  try {
    const result = await ask("discover", rates ? { rates } : {});
    $("#discover-progress").value = $("#discover-progress").max;
    $("#discover-text").textContent =
      `found ${result.motors.length} motor(s): ${result.motors.map((m) => `ID ${m.id} @ ${m.baudrate}`).join(", ") || "none"}`;
    $("#discover-text").dataset.found = result.motors.map((m) => m.id).join(",");
    setMotors(result.known ?? result.motors);
    await ask("watch", { ids: [...dashboard.motors.keys()] });
    return result;
  } finally {
    $("#discover").disabled = false;
  }
}
$("#discover").onclick = act("discover", () => {
  const choice = $("#discover-rates").value;
  return runDiscovery(choice === "all" ? null : [Number(choice)]);
});

function showProgress(p) {
  dashboard.progressEvents = (dashboard.progressEvents ?? 0) + 1;
  $("#discover-progress").max = p.total;
  $("#discover-progress").value = p.index + 1;
  const walking = p.walking_id != null ? `, pinging ID ${p.walking_id}` : "";
  $("#discover-text").textContent =
    `${p.rate} bps (${p.index + 1}/${p.total})${walking}; found so far: ${p.found.join(", ") || "none"}`;
  for (const info of p.motors ?? []) if (!dashboard.motors.has(info.id)) addMotor(info); // cards appear as found
}

// ---- motor cards and live plots -----------------------------------------------------------
function setMotors(motors) {
  const wanted = new Set(motors.map((m) => m.id));
  for (const [id, motor] of dashboard.motors) {
    if (!wanted.has(id)) {
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
  refreshMotorSelects();
  rebuildOverlay();
}

function addMotor(info) {
  dashboard.motors.set(info.id, makeCard(info));
  const cards = [...dashboard.motors.values()].sort((a, b) => a.info.id - b.info.id).map((m) => m.card);
  $("#cards").replaceChildren(...cards);
  refreshMotorSelects();
  rebuildOverlay();
}

function refreshMotorSelects() {
  const ids = [...dashboard.motors.keys()].sort((a, b) => a - b);
  for (const select of document.querySelectorAll(".motor-select")) {
    const current = select.value;
    select.replaceChildren(...ids.map((id) => build("option", { value: id, textContent: `ID ${id}` })));
    if (ids.includes(Number(current))) select.value = current;
  }
  updateResetPhrase();
}

const subtitle = (info) => `${info.baudrate} bps · firmware ${info.firmware ?? "?"}`;

function makeCard(info) {
  const id = info.id;
  const card = build("div", { className: "card", id: `motor-${id}` });
  card.dataset.id = id;
  const readout = build("div", { className: "readout" });
  const field = (name, label, unit, title) => {
    const value = build("b", { className: name, textContent: "–" });
    readout.append(build("span", { title }, `${label} `, value, ` ${unit}`));
    return value;
  };
  const motor = {
    info,
    series: { t: [], position: [], speed: [], current: [], device: [], target: [] },
    target: null, // the last move's target on the continuous scale, drawn with the actual position
    dirty: false,
    paused: false,
    values: {
      position: field("position", "position", "°", "continuous: counts whole turns since the console started"),
      device: field(
        "device",
        "device",
        "°",
        `what the controller reports, within ±${DEVICE_LIMIT}°; moves are given in this frame (±${MOVE_LIMIT}°)`,
      ),
      speed: field("speed", "speed", "RPM"),
      current: field("current", "current", "A"),
    },
    badge: build("span", { className: "control-state" }),
    subtitle: build("small", { textContent: subtitle(info) }),
    card,
  };
  const pause = build("button", { textContent: "Pause", className: "small" });
  const csv = build("button", {
    textContent: "CSV",
    className: "small",
    title: "export the kept samples (last minute)",
  });
  card.append(
    build("h2", {}, `ID ${id}`, motor.subtitle, motor.badge, build("span", { className: "spacer" }), pause, csv),
    readout,
  );
  const plotBox = build("div", { className: "plot" });
  card.append(plotBox);
  motor.plot = livePlot(
    plotBox,
    [
      { label: "position °", scale: "deg", stroke: COLOURS[0], width: 1.5 },
      { label: "target °", scale: "deg", stroke: "#9ca3af", dash: [6, 4], width: 1 },
      { label: "speed RPM", scale: "rpm", stroke: COLOURS[1], width: 1 },
      { label: "current A", scale: "amp", stroke: COLOURS[2], width: 1 },
    ],
    [
      { scale: "deg", label: "°", size: 50 },
      { scale: "rpm", side: 1, label: "RPM", grid: { show: false }, size: 50 },
      { scale: "amp", side: 1, label: "A", grid: { show: false }, size: 40 },
    ],
    motor,
  );
  pause.onclick = () => setPaused(motor, !motor.paused, pause);
  motor.pauseButton = pause;
  csv.onclick = () => download(`nurimc-motor-${id}.csv`, seriesCsv(motor), "text/csv");

  const num = (value, title, attrs = {}) => build("input", { type: "number", value, step: "any", title, ...attrs });
  const target = num(90, `degrees (device frame, ±${MOVE_LIMIT}°)`),
    moveRpm = num(60, "RPM (above 0)", { min: 0.1 }),
    runRpm = num(30, "RPM (negative: clockwise)");
  const by = build("input", { type: "checkbox", title: "move by this amount from where the motor is" });
  const button = (text, handler, title = "") => build("button", { textContent: text, onclick: handler, title });
  card.append(
    build(
      "div",
      { className: "controls" },
      "to ",
      target,
      "° at ",
      moveRpm,
      " RPM ",
      build("label", {}, by, " by"),
      button(
        "Move",
        act(`ID ${id} move`, async () => {
          const degrees = readNumber(target, "to", { min: -100000, max: 100000 });
          const rpm = readNumber(moveRpm, "move RPM", { above: 0, max: 6553.3 });
          const device = lastOf(motor.series.device);
          const aim = by.checked && device != null ? device + degrees : degrees;
          if (Math.abs(aim) > MOVE_LIMIT) {
            throw new InputProblem(
              `the target ${aim.toFixed(2)}° is outside the device's range ±${MOVE_LIMIT}° (moves are in the device's frame; it is at ${device?.toFixed(2) ?? "?"}°): move back or use Set zero here first`,
            );
          }
          await ask("move", { id, degrees, rpm, relative: by.checked });
          const offset = lastOf(motor.series.position) - (device ?? 0);
          motor.target = (by.checked ? (device ?? 0) + degrees : degrees) + (Number.isFinite(offset) ? offset : 0);
          setControl(motor, "on");
        }),
      ),
    ),
    build(
      "div",
      { className: "controls" },
      "run at ",
      runRpm,
      " RPM ",
      button(
        "Run",
        act(`ID ${id} run`, async () => {
          const rpm = readNumber(runRpm, "run RPM", { min: -6553.3, max: 6553.3, nonzero: true });
          await ask("run", { id, rpm, ramp: 0.5 });
          motor.target = null;
          setControl(motor, "on");
        }),
      ),
      button(
        "Release",
        act(`ID ${id} release`, async () => {
          await ask("release", { id });
          motor.target = null;
          setControl(motor, "off");
        }),
      ),
      button(
        "Hold",
        act(`ID ${id} hold`, async () => {
          await ask("hold", { id });
          motor.target = lastOf(motor.series.position);
          setControl(motor, "on");
        }),
      ),
      button(
        "Set zero",
        act(`ID ${id} set zero`, async () => {
          const answer = await ask("set_zero", { id });
          motor.target = null;
          say(`ID ${id}: the current position is now 0° (device reads ${answer.device_position.toFixed(2)}°)`);
        }),
        "make the current position the device's zero (its ±655.35° range starts here)",
      ),
    ),
  );
  return motor;
}

const lastOf = (array) => (array.length ? array[array.length - 1] : null);

/** A uPlot whose x axis is seconds relative to now, that fills its box, shows values on hover,
 *  and holds a zoom (zooming pauses the live updates; double-click resets and resumes). */
function livePlot(box, series, axes, owner) {
  const plot = new uPlot(
    {
      width: Math.max(box.clientWidth, 280),
      height: 220,
      legend: { live: true },
      cursor: { drag: { x: true, y: false } },
      scales: { x: { time: false }, deg: {}, rpm: {}, amp: {} },
      series: [{ label: "t (s)", value: (u, v) => (v == null ? "–" : `${v.toFixed(2)} s`) }, ...series],
      axes: [{ label: "seconds (0 = now)" }, ...axes],
      hooks: {
        setSelect: [
          (u) => {
            if (u.select.width > 2) {
              owner.zoomed = true;
              setPaused(owner, true);
            }
          },
        ],
      },
    },
    [[], ...series.map(() => [])],
    box,
  );
  plot.over.addEventListener("dblclick", () => {
    owner.zoomed = false;
    setPaused(owner, false);
  });
  new ResizeObserver(() => {
    const width = Math.max(box.clientWidth, 200);
    if (Math.abs(width - plot.width) > 2) plot.setSize({ width, height: 220 });
  }).observe(box);
  return plot;
}

function setPaused(owner, paused) {
  owner.paused = paused;
  if (owner.pauseButton) owner.pauseButton.textContent = paused ? "Resume" : "Pause";
  if (owner.card) owner.card.dataset.paused = paused ? "yes" : "no";
  if (!paused) {
    owner.zoomed = false;
    owner.dirty = true;
  }
}

function setControl(motor, control) {
  motor.badge.textContent = control === "off" ? "released" : control === "on" ? "" : "control unknown";
  motor.badge.className = `control-state ${control === "off" ? "released" : ""}`;
  motor.card.dataset.control = control;
}

function addSamples(rows) {
  dashboard.samplesReceived += rows.length;
  for (const [id, serverT, position, speed, current, device] of rows) {
    const motor = dashboard.motors.get(id);
    if (!motor) continue;
    const t = serverT + dashboard.clockOffset;
    if (motor.series.t.length && t <= lastOf(motor.series.t)) continue; // the time axis only moves forward
    const s = motor.series;
    s.t.push(t);
    s.position.push(position);
    s.speed.push(speed);
    s.current.push(current);
    s.device.push(device ?? position);
    s.target.push(motor.target);
    let drop = 0;
    while (drop < s.t.length && s.t[drop] < t - KEEP_S) drop++;
    if (drop) for (const key of Object.keys(s)) s[key].splice(0, drop);
    motor.latest = t;
    motor.dirty = true;
    overlay.dirty = true;
  }
}

function windowOf(s, now) {
  let first = s.t.length;
  while (first > 0 && s.t[first - 1] >= now - WINDOW_S) first--;
  return first;
}

function redraw() {
  for (const motor of dashboard.motors.values()) {
    if (!motor.dirty) continue;
    motor.dirty = false;
    const s = motor.series;
    const last = s.t.length - 1;
    if (last < 0) continue;
    motor.values.position.textContent = s.position[last].toFixed(2);
    motor.values.device.textContent = s.device[last].toFixed(2);
    motor.values.speed.textContent = s.speed[last].toFixed(1);
    motor.values.current.textContent = s.current[last].toFixed(1);
    motor.card.dataset.lastPosition = s.position[last];
    motor.card.dataset.devicePosition = s.device[last];
    if (motor.paused) continue;
    const now = s.t[last];
    const from = windowOf(s, now);
    motor.plot.setData([
      s.t.slice(from).map((t) => t - now),
      s.position.slice(from),
      s.target.slice(from),
      s.speed.slice(from),
      s.current.slice(from),
    ]);
  }
  if (overlay.dirty && !overlay.paused && overlay.plot && !$("#view-plot").classList.contains("hidden")) drawOverlay();
  requestAnimationFrame(redraw);
}
requestAnimationFrame(redraw);

function seriesCsv(motor) {
  const s = motor.series;
  const lines = ["t_s,position_deg,device_position_deg,speed_rpm,current_a,target_deg"];
  for (let i = 0; i < s.t.length; i++)
    lines.push([s.t[i], s.position[i], s.device[i], s.speed[i], s.current[i], s.target[i] ?? ""].join(","));
  return lines.join("\n") + "\n";
}

// ---- overlay of every motor ---------------------------------------------------------------
const overlay = { plot: null, dirty: false, paused: false, ids: [] };
dashboard.overlay = overlay;
const OVERLAY_UNITS = { position: "°", device: "°", speed: "RPM", current: "A" };
function rebuildOverlay() {
  overlay.plot?.destroy();
  overlay.plot = null;
  overlay.ids = [...dashboard.motors.keys()].sort((a, b) => a - b);
  if (!overlay.ids.length) return;
  const quantity = $("#overlay-quantity").value;
  const box = $("#overlay-plot");
  box.replaceChildren();
  overlay.plot = livePlot(
    box,
    overlay.ids.map((id, i) => ({
      label: `ID ${id} ${OVERLAY_UNITS[quantity]}`,
      scale: "deg",
      stroke: COLOURS[i % COLOURS.length],
      width: 1.5,
    })),
    [{ scale: "deg", label: OVERLAY_UNITS[quantity], size: 50 }],
    overlay,
  );
  overlay.dirty = true;
}
function drawOverlay() {
  overlay.dirty = false;
  const quantity = $("#overlay-quantity").value;
  let now = -Infinity;
  for (const id of overlay.ids) now = Math.max(now, dashboard.motors.get(id)?.latest ?? -Infinity);
  if (!Number.isFinite(now)) return;
  // one time axis: every motor's samples, each series null where another motor was read
  const rows = [];
  overlay.ids.forEach((id, k) => {
    const s = dashboard.motors.get(id).series;
    for (let i = windowOf(s, now); i < s.t.length; i++) rows.push([s.t[i], k, s[quantity][i]]);
  });
  rows.sort((a, b) => a[0] - b[0]);
  const data = [rows.map((r) => r[0] - now), ...overlay.ids.map((_, k) => rows.map((r) => (r[1] === k ? r[2] : null)))];
  overlay.plot.setData(data);
}
$("#overlay-quantity").onchange = rebuildOverlay;
$("#overlay-pause").onclick = () => {
  setPaused(overlay, !overlay.paused);
  $("#overlay-pause").textContent = overlay.paused ? "Resume" : "Pause";
};
$("#overlay-csv").onclick = () => {
  const lines = ["motor_id,t_s,position_deg,device_position_deg,speed_rpm,current_a"];
  for (const [id, motor] of dashboard.motors) {
    const s = motor.series;
    for (let i = 0; i < s.t.length; i++)
      lines.push([id, s.t[i], s.position[i], s.device[i], s.speed[i], s.current[i]].join(","));
  }
  download("nurimc-motors.csv", lines.join("\n") + "\n", "text/csv");
};

// ---- emergency stop -----------------------------------------------------------------------
async function emergencyStop() {
  dashboard.stops += 1; // ends a running sequence at once, whatever the server answers
  stopSequence("emergency stop");
  const button = $("#estop");
  if (!dashboard.link || !dashboard.connected) {
    button.dataset.lastResult = "unreachable";
    estopAlarm("E-STOP NOT SENT: the server is unreachable. Cut the motors' power now.");
    return;
  }
  button.dataset.lastResult = "sending";
  const stop = dashboard.stops;
  clearTimeout(dashboard.estopTimer);
  dashboard.estopTimer = setTimeout(() => {
    if (button.dataset.lastResult !== "sending" || dashboard.stops !== stop) return;
    button.dataset.lastResult = "no receipt";
    estopAlarm(
      `E-STOP NOT CONFIRMED: the server did not answer within ${ESTOP_RECEIPT_MS / 1000} s. Cut the motors' power now.`,
    );
  }, ESTOP_RECEIPT_MS);
  try {
    await dashboard.link.request("estop");
  } catch (error) {
    button.dataset.lastResult = "failed";
    estopAlarm(`E-STOP may not have reached the motors (${error.message}): cut the power`);
  }
}

function estopAlarm(text) {
  $("#banner").classList.remove("hidden");
  $("#banner-text").textContent = text;
  say(text, "error");
}
$("#estop").onclick = emergencyStop;
document.addEventListener("keydown", (event) => {
  if (event.key === "Escape") {
    event.preventDefault();
    emergencyStop();
  }
});

function showEstop(m) {
  dashboard.stops += 1;
  stopSequence("emergency stop");
  const entries = Object.entries(m.control);
  for (const [id, control] of entries) {
    const motor = dashboard.motors.get(Number(id));
    if (motor) {
      setControl(motor, control === "off" ? "off" : "unknown");
      motor.target = null;
    }
  }
  const bad = entries.filter(([, control]) => control !== "off");
  say(
    bad.length
      ? `EMERGENCY STOP sent at ${m.rates.join(", ")} bps, but not confirmed for ${bad.map(([id, c]) => `ID ${id} (${c})`).join(", ")}: cut the power`
      : `EMERGENCY STOP: control off sent at ${m.rates.join(", ")} bps; ${entries.length} motor(s) confirmed released. Nothing moves until you give a new command.`,
    bad.length ? "error" : "info",
  );
  $("#estop").dataset.lastResult = JSON.stringify(m.control);
  $("#estop").dataset.rates = m.rates.join(",");
  if (dashboard.connected && !bad.length) $("#banner").classList.add("hidden"); // a late answer replaces a "not confirmed" alarm
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
    input.ariaLabel = s.name;
    input.oninput = () => {
      input.dataset.edited = "yes";
    }; // a read-back must not overwrite what the user types
    const result = build("td", { className: "result" });
    const write = build("button", { textContent: "Write", disabled: !s.writable });
    const row = build(
      "tr",
      { id: `setting-${s.name}` },
      build("td", { textContent: s.name, title: s.doc }),
      build("td", { className: "value" }),
      build("td", {}, input),
      build("td", { textContent: `${s.range}` }),
      build("td", {}, write),
      result,
    );
    write.onclick = async () => {
      const id = Number($("#settings-motor").value);
      result.className = "result";
      let value;
      try {
        value = s.choices.length ? input.value : readNumber(input, s.name, { min: s.min, max: s.max });
      } catch (error) {
        result.textContent = error.message;
        result.className = "result bad";
        return;
      }
      result.textContent = "writing…";
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

async function readSettings(selectId = "#settings-motor") {
  const id = Number($(selectId).value);
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
$("#settings-read").onclick = act("read settings", () => readSettings());
$("#settings-motor").onchange = () => {
  for (const input of document.querySelectorAll("#settings-table [data-edited]")) delete input.dataset.edited;
  readSettings().catch(() => {});
};

// ---- step response ------------------------------------------------------------------------
let stepPlot = null;
const STEP_KEEP = 6; // runs overlaid for comparison
$("#step-run").onclick = act("step", async () => {
  const id = Number($("#step-motor").value);
  const amplitude = readNumber($("#step-amplitude"), "step", {
    min: -2 * MOVE_LIMIT,
    max: 2 * MOVE_LIMIT,
    nonzero: true,
  });
  const rpm = readNumber($("#step-rpm"), "step RPM", { above: 0, max: 6553.3 });
  const duration = readNumber($("#step-duration"), "record", { min: 0.2, max: 10 });
  $("#step-run").disabled = true;
  $("#step-figures").textContent = "stepping…";
  try {
    const r = await ask("step", { id, amplitude, rpm, duration });
    const gains = ["kp", "ki", "kd"].map((k) => $(`#gain-${k}`).value).join("/");
    r.label = `#${dashboard.stepRuns.length + 1} ID ${id} ${amplitude}° Kp/Ki/Kd ${gains}`;
    dashboard.lastStep = r;
    dashboard.stepRuns.push(r);
    if (dashboard.stepRuns.length > STEP_KEEP) dashboard.stepRuns.shift();
    drawSteps();
    const rise = r.rise_time == null ? "not reached" : `${(r.rise_time * 1000).toFixed(0)} ms`;
    $("#step-figures").textContent =
      `rise time (10–90 %): ${rise} · overshoot: ${r.overshoot.toFixed(1)} % · final error: ${r.final_error} ° · ${r.settled ? "settled" : "not settled"}`;
  } catch (error) {
    $("#step-figures").textContent = "";
    throw error;
  } finally {
    $("#step-run").disabled = false;
  }
});

function drawSteps() {
  stepPlot?.destroy();
  stepPlot = null;
  const runs = dashboard.stepRuns;
  if (!runs.length) {
    $("#step-plot").replaceChildren();
    return;
  }
  // each run relative to its own start, so runs from different positions overlay
  const times = [...new Set(runs.flatMap((r) => r.times))].sort((a, b) => a - b);
  const lookup = (r) => {
    const m = new Map(r.times.map((t, i) => [t, r.positions[i] - r.start]));
    return times.map((t) => m.get(t) ?? null);
  };
  const last = runs[runs.length - 1];
  const data = [times, times.map(() => last.target - last.start), ...runs.map(lookup)];
  const series = [
    { label: "t (s)" },
    { label: "target (Δ°)", stroke: "#9ca3af", dash: [6, 4] },
    ...runs.map((r, i) => ({
      label: r.label,
      stroke: COLOURS[i % COLOURS.length],
      width: i === runs.length - 1 ? 2.5 : 1,
      spanGaps: true,
    })),
  ];
  const box = $("#step-plot");
  stepPlot = new uPlot(
    {
      width: Math.max(box.clientWidth, 280),
      height: 320,
      legend: { live: true },
      scales: { x: { time: false } },
      series,
      axes: [{ label: "seconds since the step" }, { label: "° from start", size: 50 }],
    },
    data,
    box,
  );
}
new ResizeObserver(() => {
  if (stepPlot) stepPlot.setSize({ width: Math.max($("#step-plot").clientWidth, 200), height: 320 });
}).observe($("#step-plot"));
$("#step-clear").onclick = () => {
  dashboard.stepRuns = [];
  drawSteps();
};
$("#step-csv").onclick = () => {
  const lines = ["run,motor_id,t_s,position_deg,start_deg,target_deg"];
  dashboard.stepRuns.forEach((r, k) => {
    r.times.forEach((t, i) => {
      lines.push([k + 1, r.id, t, r.positions[i], r.start, r.target].join(","));
    });
  });
  download("nurimc-steps.csv", lines.join("\n") + "\n", "text/csv");
};

async function prefillGains() {
  const id = Number($("#step-motor").value);
  if (!Number.isFinite(id) || !$("#step-motor").value) return;
  const answer = await ask("read_settings", { id });
  for (const k of ["kp", "ki", "kd"]) $(`#gain-${k}`).value = answer.settings[`position-${k}`];
  $("#gains-text").textContent = `gains of ID ${id} as read from the motor`;
  dashboard.gainsShownFor = id;
}
$("#step-motor").onchange = () => prefillGains().catch(() => {});

$("#gains-write").onclick = act("gains", async () => {
  const id = Number($("#step-motor").value);
  const gains = {
    "position-kp": readNumber($("#gain-kp"), "Kp", { min: 1, max: 254, integer: true }),
    "position-ki": readNumber($("#gain-ki"), "Ki", { min: 0, max: 254, integer: true }),
    "position-kd": readNumber($("#gain-kd"), "Kd", { min: 0, max: 254, integer: true }),
  };
  for (const [name, value] of Object.entries(gains)) {
    const answer = await ask("set", { id, name, value });
    $("#gains-text").textContent = `${name} = ${answer.value} (verified)`;
  }
});

// ---- sequences ----------------------------------------------------------------------------
const STEP_FIELDS = {
  move: [
    ["id", "ID", 1],
    ["degrees", "to °", 90],
    ["rpm", "RPM", 60],
  ],
  wait: [["seconds", "seconds", 1]],
  set: [
    ["id", "ID", 1],
    ["name", "setting", "position-kp"],
    ["value", "value", 50],
  ],
  release: [["id", "ID", 1]],
};
let sequenceRun = null;

function addSequenceStep(kind, values = {}) {
  const step = { kind, values: {} };
  for (const [key, , fallback] of STEP_FIELDS[kind]) step.values[key] = values[key] ?? fallback;
  dashboard.sequence.push(step);
  renderSequence();
}

function renderSequence() {
  const items = dashboard.sequence.map((step, index) => {
    const inputs = STEP_FIELDS[step.kind].map(([key, label]) => {
      const isText = key === "name" || (key === "value" && typeof step.values[key] === "string");
      const input = build("input", {
        type: isText ? "text" : "number",
        step: "any",
        value: step.values[key] ?? "",
        ariaLabel: label,
      });
      input.dataset.key = key;
      input.oninput = () => {
        step.values[key] = input.value;
      };
      return build("label", {}, `${label} `, input);
    });
    const remove = build("button", { textContent: "✕", title: "remove this step", className: "small" });
    remove.onclick = () => {
      dashboard.sequence.splice(index, 1);
      renderSequence();
    };
    const up = build("button", { textContent: "↑", title: "move up", className: "small", disabled: index === 0 });
    up.onclick = () => {
      dashboard.sequence.splice(index - 1, 0, dashboard.sequence.splice(index, 1)[0]);
      renderSequence();
    };
    return build("li", { className: "seq-step" }, build("b", { textContent: step.kind }), ...inputs, up, remove);
  });
  $("#seq-list").replaceChildren(...items);
}

/** A sequence step checked the way the fields are: a blank or invalid field stops the run before it starts. */
function checkedStep(step, index) {
  const field = (key) => $("#seq-list").children[index].querySelector(`[data-key="${key}"]`);
  const where = `step ${index + 1} (${step.kind})`;
  const n = (key, opts) => readNumber(field(key), `${where} ${key}`, opts);
  switch (step.kind) {
    case "move":
      return {
        op: "move",
        args: {
          id: n("id", { min: 0, max: 254, integer: true }),
          degrees: n("degrees", { min: -MOVE_LIMIT, max: MOVE_LIMIT }),
          rpm: n("rpm", { above: 0, max: 6553.3 }),
        },
      };
    case "wait":
      return { wait: n("seconds", { min: 0, max: 3600 }) };
    case "release":
      return { op: "release", args: { id: n("id", { min: 0, max: 254, integer: true }) } };
    case "set": {
      const name = field("name").value.trim();
      const raw = field("value").value.trim();
      if (!name || !raw) throw new InputProblem(`${where}: give a setting name and a value`);
      const numeric = /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(raw);
      return {
        op: "set",
        args: { id: n("id", { min: 0, max: 254, integer: true }), name, value: numeric ? Number(raw) : raw },
      };
    }
  }
  throw new InputProblem(`${where}: unknown kind`);
}

function stopSequence(why) {
  if (!sequenceRun) return;
  sequenceRun.stopped = why;
  sequenceRun.wake?.();
}

$("#seq-run").onclick = act("sequence", async () => {
  if (sequenceRun) throw new InputProblem("a sequence is already running");
  const steps = dashboard.sequence.map(checkedStep);
  if (!steps.length) throw new InputProblem("add a step first");
  const run = { stopped: null, stops: dashboard.stops };
  sequenceRun = run;
  const status = $("#seq-status");
  status.dataset.state = "running";
  try {
    for (const [index, step] of steps.entries()) {
      if (run.stopped || dashboard.stops !== run.stops) break;
      status.textContent = `running step ${index + 1} of ${steps.length}`;
      if (step.wait != null) {
        await new Promise((resolve) => {
          const timer = setTimeout(resolve, step.wait * 1000);
          run.wake = () => {
            clearTimeout(timer);
            resolve();
          };
        });
      } else {
        await ask(step.op, step.args);
      }
    }
    const stopped = run.stopped || (dashboard.stops !== run.stops ? "emergency stop" : null);
    status.textContent = stopped ? `stopped (${stopped})` : `done: ${steps.length} steps`;
    status.dataset.state = stopped ? "stopped" : "done";
  } catch (error) {
    status.textContent = `stopped: ${error.message}`;
    status.dataset.state = "failed";
    throw error;
  } finally {
    sequenceRun = null;
  }
});
$("#seq-stop").onclick = () => stopSequence("stopped by you");
$("#seq-add-move").onclick = () => addSequenceStep("move", { id: Number($("#setup-motor").value) || 1 });
$("#seq-add-wait").onclick = () => addSequenceStep("wait");
$("#seq-add-set").onclick = () => addSequenceStep("set", { id: Number($("#setup-motor").value) || 1 });
$("#seq-add-release").onclick = () => addSequenceStep("release", { id: Number($("#setup-motor").value) || 1 });
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
$("#seq-load").onchange = act("load sequence", async (event) => {
  const file = event.target.files[0];
  if (!file) return;
  let document_;
  try {
    document_ = JSON.parse(await file.text());
  } catch (error) {
    throw new InputProblem(`${file.name} is not JSON (${error.message})`);
  }
  loadSequence(document_);
  event.target.value = "";
});
function loadSequence(document_) {
  if (document_?.format !== "nurimc-sequence/1" || !Array.isArray(document_.steps))
    throw new InputProblem("not a nurimc sequence (format nurimc-sequence/1)");
  const steps = document_.steps.map((s, i) => {
    if (!STEP_FIELDS[s?.kind]) throw new InputProblem(`step ${i + 1}: unknown kind ${JSON.stringify(s?.kind)}`);
    return s;
  });
  dashboard.sequence = [];
  for (const { kind, ...values } of steps) addSequenceStep(kind, values);
}
dashboard.loadSequence = loadSequence;

// ---- setup: ID, baud, factory reset, the server's port ------------------------------------
function updateResetPhrase() {
  const id = $("#setup-motor").value;
  $("#reset-phrase").textContent = `RESET ${id || "?"}`;
  $("#factory-reset").disabled = !id || $("#reset-confirm").value.trim() !== `RESET ${id}`;
}
$("#setup-motor").onchange = updateResetPhrase;
$("#reset-confirm").oninput = updateResetPhrase;
$("#change-id").onclick = act("change ID", async () => {
  const id = Number($("#setup-motor").value);
  const newId = readNumber($("#new-id"), "new ID", { min: 0, max: 254, integer: true });
  $("#setup-text").textContent = "changing the ID…";
  await ask("change_id", { id, new_id: newId });
  $("#setup-text").textContent = `ID ${id} is now ID ${newId} (verified)`;
});
$("#change-baud").onclick = act("change baud", async () => {
  const id = Number($("#setup-motor").value);
  const rate = Number($("#new-baud").value);
  $("#setup-text").textContent = "changing the baud rate…";
  const answer = await ask("change_baud", { id, baudrate: rate });
  $("#setup-text").textContent = `ID ${id} now answers at ${answer.baudrate} bps (verified)`;
});
$("#factory-reset").onclick = act("factory reset", async () => {
  const id = Number($("#setup-motor").value);
  const answer = await ask("factory_reset", { id, confirm: $("#reset-confirm").value.trim() });
  $("#reset-confirm").value = "";
  updateResetPhrase();
  $("#setup-text").textContent = `ID ${id} reset: ${answer.note}`;
});
async function loadPorts() {
  const answer = await ask("ports");
  $("#bus-port").replaceChildren(
    ...answer.ports.map((p) => build("option", { value: p, textContent: p, selected: p === answer.current })),
  );
  $("#bus-baud").value = String(answer.baudrate);
  $("#bus-text").textContent = `open: ${answer.current} at ${answer.baudrate} bps`;
}
$("#bus-open").onclick = act("open bus", async () => {
  try {
    const answer = await ask("open_bus", { port: $("#bus-port").value, baudrate: Number($("#bus-baud").value) });
    $("#bus-text").textContent = `open: ${answer.port} at ${answer.baudrate} bps`;
  } catch (error) {
    $("#bus-text").textContent = `not opened: ${error.message}`; // said beside the picker, not only in a message
    throw error;
  }
});

// ---- backup / restore ---------------------------------------------------------------------
$("#backup").onclick = act("backup", async () => {
  const ids = [...dashboard.motors.keys()];
  if (!ids.length) throw new InputProblem("discover motors first");
  const document_ = await ask("backup", { ids });
  const text = JSON.stringify(document_, null, 2);
  $("#backup-text").textContent = text;
  download(`nurimc-backup-${document_.time}.json`, text, "application/json");
});

$("#restore-file").onchange = act("restore", async (event) => {
  const file = event.target.files[0];
  if (!file) return;
  let document_;
  try {
    document_ = JSON.parse(await file.text());
  } catch (error) {
    throw new InputProblem(`${file.name} is not JSON (${error.message})`);
  }
  const result = await ask("restore", { document: document_ });
  $("#backup-text").textContent = result.changed.length
    ? `restored (each verified):\n${result.changed.join("\n")}`
    : "nothing to change: every setting already matches";
});

function download(name, text, type) {
  const link = build("a", { href: URL.createObjectURL(new Blob([text], { type })), download: name });
  link.click();
  setTimeout(() => URL.revokeObjectURL(link.href), 1000);
}

// ---- raw frames ---------------------------------------------------------------------------
$("#raw-on").onchange = act("raw frames", async (event) => {
  const result = await ask("frames", { on: event.target.checked });
  if (event.target.checked) {
    dashboard.frames = result.recent;
    renderFrames();
  }
});
$("#raw-filter").oninput = () => renderFrames();
$("#raw-export").onclick = () =>
  download(
    "nurimc-frames.jsonl",
    filteredFrames()
      .map((f) => JSON.stringify(f))
      .join("\n") + "\n",
    "application/x-ndjson",
  );

function addFrames(frames) {
  dashboard.frames.push(...frames);
  if (dashboard.frames.length > 20000) dashboard.frames.splice(0, dashboard.frames.length - 20000);
  rawDirty = true;
}
let rawDirty = false;
setInterval(() => {
  if (rawDirty && !$("#raw-pause").checked) {
    rawDirty = false;
    renderFrames();
  }
}, 250);

function filteredFrames() {
  const terms = $("#raw-filter")
    .value.toLowerCase()
    .split(/[\s,]+/)
    .filter(Boolean);
  return dashboard.frames.filter((f) =>
    terms.every((term) => {
      if (term.startsWith("id=")) return String(f.id) === term.slice(3);
      return f.dir === term || (f.name ?? "").includes(term) || f.hex.includes(term);
    }),
  );
}

function renderFrames() {
  const frames = filteredFrames();
  $("#raw-count").textContent = `${frames.length} of ${dashboard.frames.length} frames`;
  const rows = frames
    .slice(-RAW_ROWS)
    .reverse()
    .map((f) =>
      build(
        "tr",
        {},
        build("td", { textContent: f.t.toFixed(4) }),
        build("td", { textContent: f.dir }),
        build("td", { textContent: f.id ?? "" }),
        build("td", { textContent: f.name }),
        build("td", { textContent: JSON.stringify(f.fields) }),
        build("td", { textContent: f.hex }),
      ),
    );
  $("#raw-table tbody").replaceChildren(...rows);
}

// ---- views --------------------------------------------------------------------------------
for (const button of document.querySelectorAll("nav button")) {
  button.onclick = () => {
    for (const other of document.querySelectorAll("nav button")) other.classList.toggle("active", other === button);
    for (const view of document.querySelectorAll(".view"))
      view.classList.toggle("hidden", view.id !== `view-${button.dataset.view}`);
    const view = button.dataset.view;
    if (!dashboard.connected) return;
    if (view === "settings" && dashboard.motors.size) readSettings().catch(() => {});
    if (view === "step" && dashboard.motors.size) prefillGains().catch(() => {});
    if (view === "plot") {
      overlay.dirty = true;
    }
    if (view === "setup" && dashboard.mode === "server") loadPorts().catch(() => {});
  };
}

window.addEventListener("unhandledrejection", (event) => {
  event.preventDefault(); // reported where it happened; never "Uncaught (in promise)"
  if (!event.reason?.reported) say(String(event.reason?.message ?? event.reason), "error");
});

start().catch((error) => setStatus(`start failed: ${error.message}`));
