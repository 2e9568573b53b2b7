// The server's bus port across an outage: the persistent "port lost … reconnecting" banner (with
// how long), "port back" while the motors are read again, and the latched emergency stop
// ("stop pending: port lost") until the server's `estop` with latched=true confirms it.
// The state itself is folded by core/portstate.js; the stop banner is drawn by connection.js.
import { $, $$ } from "../core/dom.js";
import { onLanguage, serverError, t } from "../core/i18n.js";
import { nextPortState, PORT_UP, portBanner } from "../core/portstate.js";
import { dashboard, emit } from "../core/store.js";
import { act, ask, say, sayError } from "./messages.js";

const now = () => performance.now() / 1000;
dashboard.port = PORT_UP;
dashboard.portDown = false;
dashboard.stopPending = null; // { message, at }: an emergency stop latched by the server, not yet carried out

/** The latched stop: set (with the server's message) or cleared (the stop was carried out). */
export function setStopPending(message) {
  const was = dashboard.stopPending;
  dashboard.stopPending = message ? { message, at: was?.at ?? new Date() } : null;
  if (Boolean(was) !== Boolean(message) || (message && was?.message !== message))
    emit("stop-pending", dashboard.stopPending);
}

function take(message) {
  const before = dashboard.port;
  const state = nextPortState(before, message, now());
  dashboard.port = state;
  if (before.phase !== state.phase) $("#port-banner-detail").textContent = ""; // an old "cannot reopen"
  dashboard.portDown = state.phase === "lost";
  document.body.classList.toggle("port-down", dashboard.portDown);
  // the server's word on the latch; an `estop_pending` or the stop's own reply may come first
  if (!state.stopPending && dashboard.stopPending && message.type === "port" && message.state !== "lost")
    setStopPending(null);
  if (state.stopPending && !dashboard.stopPending) setStopPending(message.port_state?.message ?? message.message ?? "");
  if (message.type === "hello" && !state.stopPending && dashboard.stopPending) setStopPending(null);
  showBanner();
  emit("port", state);
  return state;
}

function showBanner() {
  const box = $("#port-banner");
  const said = portBanner(dashboard.port, now());
  box.classList.toggle("hidden", !said);
  if (!said) return;
  box.dataset.phase = dashboard.port.phase;
  box.classList.toggle("back", dashboard.port.phase === "back");
  $("#port-banner-text").textContent = t(...said);
  $("#port-reopen").classList.toggle("hidden", dashboard.port.phase !== "lost");
  $("#port-choose").classList.toggle("hidden", dashboard.port.phase !== "lost");
}

function onPort(message) {
  const state = take(message);
  const params = { port: state.port || "?", s: (state.downFor ?? message.down_for ?? 0).toFixed(1) };
  if (message.state === "resumed") {
    say(t("port.resumed", params));
    for (const id of message.stopped ?? []) {
      const motor = dashboard.motors.get(id);
      if (motor) {
        motor.control = "off";
        motor.card.dataset.control = "off";
      }
    }
    if (message.stopped?.length)
      say(t("port.turningStopped", { list: message.stopped.map((id) => `ID ${id}`).join(", ") }));
    for (const [id, read] of Object.entries(message.states ?? {}))
      if (read.error) sayError(t("port.notReadAgain", { id }), read.error);
  }
  if (message.state === "opened") say(t("port.opened", params));
  if (message.state === "closed") say(t("port.closed", params), "error");
}

/** The server link's port messages (server mode only: direct mode has its own port). */
export function watchPort(link) {
  link.on("hello", (hello) => {
    dashboard.busRate = hello.baudrate;
    take(hello);
  });
  link.on("port", onPort);
  link.on("estop_pending", (m) => setStopPending(m.message));
  link.on("closed", () => {
    // the server itself is gone: its banner says so; what the port does is not known until hello
    dashboard.portDown = false;
    document.body.classList.remove("port-down");
    $("#port-banner").classList.add("hidden");
  });
}

/** Ask the server to reopen the lost port now (the same path), at the rate it was opened at. */
async function reopen() {
  const port = dashboard.port.port;
  try {
    const answer = await ask("open_bus", { port, baudrate: dashboard.busRate });
    emit("bus-opened", answer);
  } catch (error) {
    $("#port-banner-detail").textContent = serverError(error.message).text;
    throw error;
  }
}

export function startPort() {
  $("#port-reopen").onclick = act(() => t("op.open_bus"), reopen);
  $("#port-choose").onclick = () => {
    for (const button of $$("nav button")) if (button.dataset.view === "setup") button.click();
    $("#bus-path")?.focus();
  };
  setInterval(() => {
    if (dashboard.port.phase === "lost") showBanner(); // how long, counting
  }, 1000);
  onLanguage(showBanner);
  emit("port", dashboard.port);
}
