// The link to the bus (server websocket or direct Web Serial), the connection banner, the
// emergency stop and its persistent "stopped" banner, and the status bar.
import { $, build } from "../core/dom.js";
import { clock, num, onLanguage, serverError, t } from "../core/i18n.js";
import { BAUD_RATES, DEFAULT_BAUD } from "../core/limits.js";
import { dashboard, emit, on } from "../core/store.js";
import { DirectLink } from "../direct-link.js";
import { settingsCatalogue } from "../direct-ops.js";
import { ServerLink } from "../server-link.js";
import { act, ask, say, sayError } from "./messages.js";
import {
  addSamples,
  markStopped,
  motorError,
  readingsPerSecond,
  runDiscovery,
  setMotors,
  showProgress,
} from "./motors.js";
import { setStopPending, watchPort } from "./port.js";

const ESTOP_RECEIPT_MS = 1000; // the server confirms it got the stop at once; no receipt by then is an alarm

// ---- status line and banners ----------------------------------------------------------------
let statusKey = ["status.starting", {}];
export function setStatus(key, params = {}) {
  statusKey = [key, params];
  $("#status").textContent = t(key, params);
}
let bannerKey = null;
function setBanner(key, params = {}) {
  bannerKey = [key, params];
  $("#banner-text").textContent = t(key, params);
}
let detailKey = null;
function setDetail(key, params = {}) {
  detailKey = [key, params];
  $("#banner-detail").textContent = key ? t(key, params) : "";
}

function setConnected(connected, detail = null) {
  dashboard.connected = connected;
  $("#controls").disabled = !connected;
  document.body.classList.toggle("offline", !connected);
  $("#banner").classList.toggle("hidden", connected);
  $("#estop").classList.toggle("unreachable", !connected);
  $("#status").dataset.connected = connected ? "yes" : "no";
  if (connected) setStatus("status.connected");
  else {
    setStatus("status.notConnected");
    setBanner(dashboard.mode === "direct" ? "banner.directNotConnected" : "banner.unreachable");
    if (detail) setDetail(...detail);
  }
}

function showRetry({ delay }) {
  dashboard.retryDelays = [...(dashboard.retryDelays ?? []), delay];
  setDetail(dashboard.lostReason ? "banner.retryWhy" : "banner.retry", {
    s: num(delay / 1000, 1),
    why: serverError(dashboard.lostReason).text,
  });
  $("#banner-detail").dataset.reason = dashboard.lostReason ?? "";
}

// ---- server mode ----------------------------------------------------------------------------
async function onHello(hello) {
  if (hello.boot !== dashboard.boot) {
    // a new server process: its samples restart from 0; shift them so the plots carry on from where they were
    dashboard.boot = hello.boot;
    dashboard.clockOffset = performance.now() / 1000 - (hello.clock ?? 0);
  }
  setConnected(true);
  emit("hello", hello);
  const known = hello.motors ?? [];
  const mine = [...dashboard.motors.values()].map((m) => m.info);
  if (known.length) {
    setMotors(known);
    await ask("watch", { ids: known.map((m) => m.id) }).catch(() => {});
  } else if (mine.length) {
    // the server restarted and forgot them: look again at the rates they were at
    say(t("msg.restarted"));
    await runDiscovery([...new Set(mine.map((m) => m.baudrate))]).catch(() => {});
  } else if (!dashboard.everDiscovered) {
    await runDiscovery(null).catch(() => {});
  }
}

function useLink(link) {
  dashboard.link = link;
  link.on("samples", (m) => addSamples(m.rows));
  link.on("progress", showProgress);
  link.on("tune", (m) => emit("tune", m)); // Auto-tune trials (views/tune.js)
  link.on("frames", (m) => emit("frames", m.frames));
  link.on("estop", showEstop);
  link.on("estop_received", () => {
    if ($("#estop").dataset.lastResult === "sending") $("#estop").dataset.lastResult = "received";
  });
  link.on("motors", (m) => setMotors(m.motors));
  link.on("tick", (m) => {
    if (m.stats) takeBusStats(m.stats);
  });
  link.on("motor_error", (m) => {
    motorError(m);
    if (m.kind === "busy") say(serverError(m.message).text, "info");
    else sayError(`ID ${m.id}`, m.message);
  });
}

export async function startLink() {
  let info = null;
  try {
    const response = await fetch("./api/info", { cache: "no-store" });
    if (response.ok) info = await response.json();
  } catch {
    info = null;
  }
  if (info && info.server === "nurimc-dashboard") {
    dashboard.mode = "server";
    dashboard.sim = Boolean(info.sim);
    dashboard.settings = info.settings;
    modeBadge();
    emit("settings-catalogue", info.settings);
    setConnected(false, ["banner.connecting"]);
    const link = new ServerLink(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
    useLink(link);
    watchPort(link);
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

function modeBadge() {
  $("#mode").textContent = t(
    dashboard.mode === "direct" ? "mode.direct" : dashboard.sim ? "mode.serverSim" : "mode.server",
  );
}

// ---- direct mode ----------------------------------------------------------------------------
function fillDirectRates() {
  const rates = $("#direct-baud");
  const chosen = Number(rates.value) || DEFAULT_BAUD;
  rates.replaceChildren(
    ...BAUD_RATES.map((rate) =>
      build("option", { value: rate, textContent: `${rate} bps`, selected: rate === chosen }),
    ),
  );
}

async function startDirect() {
  dashboard.mode = "direct";
  modeBadge();
  const button = $("#connect");
  fillDirectRates();
  button.classList.remove("hidden");
  $("#direct-baud").classList.remove("hidden");
  setConnected(false, ["banner.directHow"]);
  $("#reconnect").classList.add("hidden");
  try {
    dashboard.lib = await import("../nurimc.browser.js");
  } catch {
    setStatus("status.noBundle");
    button.disabled = true;
    return;
  }
  dashboard.settings = settingsCatalogue(dashboard.lib); // the settings editor, as the server gives it
  emit("settings-catalogue", dashboard.settings);
  if (!("serial" in navigator)) {
    setStatus("status.noWebSerial");
    button.disabled = true;
    return;
  }
  setStatus("status.directReady");
  button.onclick = act(
    () => t("op.connect"),
    async () => {
      const rate = Number($("#direct-baud").value);
      const link = await new DirectLink(dashboard.lib, rate).connect();
      useLink(link);
      setConnected(true);
      setStatus("status.directConnected", { rate });
      await runDiscovery(null);
    },
  );
}

// ---- emergency stop -------------------------------------------------------------------------
async function emergencyStop() {
  dashboard.stops += 1; // ends a running sequence at once, whatever the server answers
  const button = $("#estop");
  if (!dashboard.link || !dashboard.connected) {
    emit("estop-pressed");
    button.dataset.lastResult = "unreachable";
    estopAlarm(dashboard.mode === "direct" ? "estop.notSentDirect" : "estop.notSent");
    return;
  }
  // the stop goes out first, before anything else the press sets off (the sequence's stop, banners)
  const sent = dashboard.link.request("estop");
  emit("estop-pressed");
  button.dataset.lastResult = "sending";
  const stop = dashboard.stops;
  clearTimeout(dashboard.estopTimer);
  dashboard.estopTimer = setTimeout(() => {
    if (button.dataset.lastResult !== "sending" || dashboard.stops !== stop) return;
    button.dataset.lastResult = "no receipt";
    estopAlarm("estop.notConfirmed", { s: ESTOP_RECEIPT_MS / 1000 });
  }, ESTOP_RECEIPT_MS);
  try {
    await sent;
  } catch (error) {
    if (/^stop pending/i.test(error.message)) {
      // the port is lost: the server latched the stop and sends it first when the port returns
      button.dataset.lastResult = "pending";
      setStopPending(error.message);
      return;
    }
    button.dataset.lastResult = "failed";
    estopAlarm("estop.failed", { why: serverError(error.message).text });
  }
}

function estopAlarm(key, params = {}) {
  $("#banner").classList.remove("hidden");
  setBanner(key, params);
  say(t(key, params), "error");
}

function showEstop(m) {
  dashboard.stops += 1;
  emit("estop-pressed");
  markStopped(m.control);
  const entries = Object.entries(m.control);
  const bad = entries.filter(([, control]) => control !== "off");
  const nothingRead = entries.length === 0; // never "stopped" with nothing read back (docs/service.md)
  dashboard.stopped = { at: new Date(), rates: m.rates, bad, nothingRead };
  if (m.latched) dashboard.stopped.latched = true;
  showStopBanner();
  if (m.latched) setStopPending(null); // carried out on the returned port and read back
  $("#estop").dataset.lastResult = JSON.stringify(m.control);
  $("#estop").dataset.rates = m.rates.join(",");
  if (dashboard.connected && !bad.length && !nothingRead) $("#banner").classList.add("hidden"); // a late answer replaces a "not confirmed" alarm
}

function showStopBanner() {
  const stop = dashboard.stopped;
  const pending = dashboard.stopPending;
  const box = $("#stop-banner");
  box.classList.toggle("hidden", !stop && !pending);
  box.classList.toggle("pending", Boolean(pending));
  box.dataset.state = pending ? "pending" : stop ? "done" : "";
  $("#stop-banner-close").classList.toggle("hidden", Boolean(pending)); // persistent until the server confirms it
  $("#stop-banner-until").textContent = t(pending ? "estop.pendingUntil" : "estop.until");
  if (pending) {
    $("#stop-banner-text").textContent = t("estop.pending", { time: clock(pending.at) });
    return;
  }
  if (!stop) return;
  box.classList.toggle("bad", stop.bad.length > 0 || stop.nothingRead);
  $("#stop-banner-text").textContent = stop.nothingRead
    ? t("estop.unconfirmed", { rates: stop.rates.join(", "), list: t("estop.nothingRead") })
    : stop.bad.length
      ? t("estop.unconfirmed", {
          rates: stop.rates.join(", "),
          list: stop.bad.map(([id, c]) => `ID ${id} (${serverError(c).text})`).join(", "),
        })
      : t(stop.latched ? "estop.doneLatched" : "estop.done", { rates: stop.rates.join(", "), time: clock(stop.at) });
}

// ---- status bar -----------------------------------------------------------------------------
let previousStats = null;
/** The bus's counters. Frames per second as the bus measured them on its own clock (the
 * server's frames_per_second); a bus without that figure (the direct mode's, read here at
 * once) from the change since the last reading. Never from when figures reach the page. */
function takeBusStats(stats) {
  const at = performance.now();
  if ("frames_per_second" in stats) dashboard.framesPerSecond = stats.frames_per_second;
  else if (previousStats && at > previousStats.at) {
    const frames = stats.requests + (stats.answers ?? 0) - (previousStats.requests + (previousStats.answers ?? 0));
    dashboard.framesPerSecond = Math.max(0, (frames * 1000) / (at - previousStats.at));
  }
  previousStats = { ...stats, at };
  dashboard.busStats = stats;
}

function refreshStatusBar() {
  let perSecond = 0;
  for (const motor of dashboard.motors.values()) perSecond += readingsPerSecond(motor.series.t);
  const stats = dashboard.busStats ?? dashboard.link?.stats?.() ?? null;
  const show = (v) => (v == null ? "–" : num(v, 0));
  $("#bar-frames").textContent = t("bar.frames", { n: show(dashboard.framesPerSecond ?? null) });
  $("#bar-rate").textContent = t("bar.rate", { n: num(perSecond, 0) });
  // errors while watching the motors (discovery's unanswered pings are not errors)
  $("#bar-errors").textContent = t("bar.errors", { n: show(dashboard.errors) });
  $("#bar-stale").textContent = t("bar.stale", { n: show(stats?.stale) });
  $("#bar-busy").textContent = t("bar.busy", { n: show(stats?.busy_waits) });
}

export function startConnection() {
  $("#estop").onclick = emergencyStop;
  document.addEventListener("keydown", (event) => {
    if (event.key === "Escape") {
      event.preventDefault();
      emergencyStop();
    }
  });
  $("#reconnect").onclick = () => dashboard.link?.retryNow?.();
  $("#stop-banner-close").onclick = () => {
    dashboard.stopped = false;
    showStopBanner();
  };
  on("port", (port) => {
    // the server is there but its bus is not: say so where "connected" would be
    if (!dashboard.connected) return;
    setStatus(port.phase === "lost" ? "status.portLost" : "status.connected");
    $("#status").dataset.connected = port.phase === "lost" ? "port-lost" : "yes";
  });
  on("stop-pending", (pending) => {
    if (pending) $("#estop").dataset.lastResult = "pending";
    showStopBanner();
  });
  on("command", () => {
    if (!dashboard.stopped) return;
    dashboard.stopped = false; // a new command: the stop is over
    showStopBanner();
  });
  onLanguage(() => {
    modeBadge();
    setStatus(...statusKey);
    if (bannerKey) setBanner(...bannerKey);
    if (detailKey) setDetail(...detailKey);
    showStopBanner();
    if (dashboard.mode === "direct") fillDirectRates();
  });
  setInterval(refreshStatusBar, 500);
  setInterval(() => {
    if (dashboard.mode === "direct" && dashboard.link?.stats) {
      const stats = dashboard.link.stats();
      if (stats) takeBusStats(stats);
    }
  }, 1000);
  refreshStatusBar();
}
