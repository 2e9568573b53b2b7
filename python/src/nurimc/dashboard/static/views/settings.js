// The Settings view: every setting with its range and unit (from the server's catalogue, which
// comes from the same spec), each write verified by reading back; names in the vendor's terms.
import { $, build } from "../core/dom.js";
import { onLanguage, serverError, t } from "../core/i18n.js";
import { readNumber } from "../core/input.js";
import { dashboard, on } from "../core/store.js";
import { act, ask } from "./messages.js";

function fill() {
  const body = $("#settings-table tbody");
  body.replaceChildren();
  for (const s of dashboard.settings) {
    const input = s.choices.length
      ? build("select", {}, ...s.choices.map((c) => build("option", { value: c, textContent: t(`choice.${c}`) })))
      : build("input", { type: "number", min: s.min, max: s.max, step: s.step, title: s.range });
    input.disabled = !s.writable;
    input.ariaLabel = t(`setting.${s.name}`);
    input.oninput = () => {
      input.dataset.edited = "yes";
    }; // a read-back must not overwrite what the user types
    const result = build("td", { className: "result" });
    const write = build("button", { textContent: t("settings.write"), disabled: !s.writable });
    const value = build("td", { className: "value" });
    const row = build(
      "tr",
      { id: `setting-${s.name}` },
      build(
        "td",
        { className: "name", title: t(`settingDoc.${s.name}`) },
        build("span", { textContent: t(`setting.${s.name}`) }),
        " ",
        build("code", { textContent: s.name }),
      ),
      value,
      build("td", { className: "new" }, input),
      build("td", { className: "range", textContent: rangeText(s) }),
      build("td", { className: "write" }, write),
      result,
    );
    for (const [cell, key] of [
      [value, "settings.value"],
      [row.children[2], "settings.new"],
      [row.children[3], "settings.range"],
      [result, "settings.result"],
    ])
      cell.dataset.label = t(key);
    write.onclick = async () => {
      const id = Number($("#settings-motor").value);
      result.className = "result";
      let chosen;
      try {
        chosen = s.choices.length ? input.value : readNumber(input, t(`setting.${s.name}`), { min: s.min, max: s.max });
      } catch (error) {
        result.textContent = error.message;
        result.className = "result bad";
        return;
      }
      result.textContent = t("settings.writing");
      try {
        const answer = await ask("set", { id, name: s.name, value: chosen });
        value.textContent = shown(s, answer.value);
        result.textContent = t("settings.verified", { value: shown(s, answer.value) });
        delete input.dataset.edited;
        result.className = "result ok";
      } catch (error) {
        result.textContent = serverError(error.message).text;
        result.className = "result bad";
      }
    };
    body.append(row);
  }
}

const shown = (s, value) => (s.choices?.length ? t(`choice.${value}`) : value);
function rangeText(s) {
  if (s.choices.length) return s.choices.map((c) => t(`choice.${c}`)).join(" / ");
  if (!s.writable) return t("settings.readOnly");
  const unit = s.unit === "rpm" ? "RPM" : s.unit; // one spelling of the unit on the page
  return `${s.min} … ${s.max}${unit ? ` ${unit}` : ""}`;
}

export async function readSettings() {
  const id = Number($("#settings-motor").value);
  const answer = await ask("read_settings", { id });
  for (const [name, value] of Object.entries(answer.settings)) {
    const row = document.getElementById(`setting-${name}`);
    if (!row) continue;
    const s = dashboard.settings.find((x) => x.name === name);
    row.querySelector(".value").textContent = s ? shown(s, value) : value;
    const input = row.querySelector("input, select");
    if (input && !input.disabled && !input.dataset.edited) input.value = value;
  }
  dashboard.settingsShownFor = id;
  return answer.settings;
}

export function startSettings() {
  on("settings-catalogue", fill);
  onLanguage(() => {
    fill();
    if (dashboard.connected && dashboard.settingsShownFor != null) readSettings().catch(() => {});
  });
  $("#settings-read").onclick = act(() => t("op.read_settings"), readSettings);
  $("#settings-motor").onchange = () => {
    for (const input of document.querySelectorAll("#settings-table [data-edited]")) delete input.dataset.edited;
    readSettings().catch(() => {});
  };
  on("view", (view) => {
    if (view === "settings" && dashboard.connected && dashboard.motors.size) readSettings().catch(() => {});
  });
}
