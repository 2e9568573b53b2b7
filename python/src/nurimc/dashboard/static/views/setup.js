// The ID / baud / reset view, and the server's port and rate.
import { $, build } from "../core/dom.js";
import { onLanguage, serverError, t } from "../core/i18n.js";
import { readNumber } from "../core/input.js";
import { BAUD_RATES, DEFAULT_BAUD, MAX_ID } from "../core/limits.js";
import { dashboard, emit, on } from "../core/store.js";
import { act, ask } from "./messages.js";

let textKey = null;
function setText(key, params = {}) {
  textKey = [key, params];
  $("#setup-text").textContent = t(key, params);
}
let busKey = null;
function setBus(key, params = {}) {
  busKey = [key, params];
  $("#bus-text").textContent = t(key, params);
}

function fillBauds() {
  for (const select of document.querySelectorAll(".baud-select")) {
    const chosen = Number(select.value) || DEFAULT_BAUD;
    select.replaceChildren(
      ...BAUD_RATES.map((rate) =>
        build("option", { value: rate, textContent: `${rate} bps`, selected: rate === chosen }),
      ),
    );
  }
}

export function refreshMotorSelects() {
  const ids = [...dashboard.motors.keys()].sort((a, b) => a - b);
  for (const select of document.querySelectorAll(".motor-select")) {
    const current = select.value;
    select.replaceChildren(...ids.map((id) => build("option", { value: id, textContent: `ID ${id}` })));
    if (ids.includes(Number(current))) select.value = current;
  }
  updateResetPhrase();
}

function updateResetPhrase() {
  const id = $("#setup-motor").value;
  $("#reset-phrase").textContent = `RESET ${id || "?"}`;
  $("#factory-reset").disabled = !id || $("#reset-confirm").value.trim() !== `RESET ${id}`;
}

async function loadPorts() {
  const answer = await ask("ports");
  $("#bus-port").replaceChildren(
    ...answer.ports.map((p) => build("option", { value: p, textContent: p, selected: p === answer.current })),
  );
  $("#bus-baud").value = String(answer.baudrate);
  if (dashboard.portDown) setBus("setup.lost", { port: answer.current });
  else setBus("setup.open", { port: answer.current, rate: answer.baudrate });
}

export function startSetup() {
  fillBauds();
  on("motors", refreshMotorSelects);
  on("hello", (hello) => setBus("setup.open", { port: hello.port || "?", rate: hello.baudrate }));
  on("bus-opened", (answer) => {
    dashboard.busRate = answer.baudrate;
    setBus("setup.open", { port: answer.port, rate: answer.baudrate });
    if (dashboard.view === "setup") loadPorts().catch(() => {});
  });
  on("port", (port) => {
    // while lost: Open with the same port tries it again at once; another path opens that one
    if (port.phase === "lost") setBus("setup.lost", { port: port.port || "?" });
    else if (busKey?.[0] === "setup.lost")
      setBus("setup.open", { port: port.port || "?", rate: dashboard.busRate ?? "?" });
  });
  $("#setup-motor").onchange = updateResetPhrase;
  $("#reset-confirm").oninput = updateResetPhrase;
  $("#change-id").onclick = act(
    () => t("op.change_id"),
    async () => {
      const id = Number($("#setup-motor").value);
      const newId = readNumber($("#new-id"), t("setup.newId"), { min: 0, max: MAX_ID, integer: true });
      setText("setup.changingId");
      await ask("change_id", { id, new_id: newId });
      setText("setup.idChanged", { id, newId });
    },
  );
  $("#change-baud").onclick = act(
    () => t("op.change_baud"),
    async () => {
      const id = Number($("#setup-motor").value);
      const rate = Number($("#new-baud").value);
      setText("setup.changingBaud");
      const answer = await ask("change_baud", { id, baudrate: rate });
      setText("setup.baudChanged", { id, rate: answer.baudrate });
    },
  );
  $("#factory-reset").onclick = act(
    () => t("op.factory_reset"),
    async () => {
      const id = Number($("#setup-motor").value);
      const answer = await ask("factory_reset", { id, confirm: $("#reset-confirm").value.trim() });
      $("#reset-confirm").value = "";
      updateResetPhrase();
      setText("setup.resetDone", { id, note: serverError(answer.note).text });
      $("#setup-text").dataset.note = answer.note;
    },
  );
  $("#bus-open").onclick = act(
    () => t("op.open_bus"),
    async () => {
      try {
        // a typed path wins over the list (a pty, a /dev/serial/by-id name the list does not show)
        const port = $("#bus-path").value.trim() || $("#bus-port").value;
        const answer = await ask("open_bus", { port, baudrate: Number($("#bus-baud").value) });
        $("#bus-path").value = "";
        emit("bus-opened", answer);
      } catch (error) {
        setBus("setup.notOpened", { why: serverError(error.message).text }); // said beside the picker, not only in a message
        throw error;
      }
    },
  );
  on("view", (view) => {
    if (view === "setup" && dashboard.connected && dashboard.mode === "server") loadPorts().catch(() => {});
  });
  onLanguage(() => {
    if (textKey) setText(...textKey);
    if (busKey) setBus(...busKey);
  });
}
