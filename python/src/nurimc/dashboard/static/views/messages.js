// Toasts (the same one again is counted, not stacked), and the request helpers every view uses.
import { $, build } from "../core/dom.js";
import { serverError, t } from "../core/i18n.js";
import { InputProblem } from "../core/input.js";
import { dashboard, emit } from "../core/store.js";

const MAX_TOASTS = 4;
// ops that command motion or write settings: the first one after an emergency stop ends its banner
const COMMANDS = new Set([
  "move",
  "run",
  "hold",
  "set",
  "step",
  "tune",
  "restore",
  "set_zero",
  "change_id",
  "change_baud",
  "factory_reset",
]);

export function say(text, kind = "info", detail = "") {
  const box = $("#messages");
  const same = [...box.children].find((toast) => toast.dataset.text === text);
  if (same) {
    same.dataset.count = Number(same.dataset.count ?? 1) + 1;
    same.querySelector(".count").textContent = `×${same.dataset.count}`;
    box.append(same);
    return same;
  }
  const close = build("button", {
    className: "close",
    textContent: "×",
    title: t("msg.close"),
    ariaLabel: t("msg.close"),
  });
  const toast = build(
    "div",
    { className: `message ${kind}` },
    build("span", { className: "text", textContent: text }),
    detail ? build("code", { className: "detail", textContent: detail }) : null,
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

/** An error from the server or the library, in the page's language (the English original kept beside it). */
export function sayError(prefix, message) {
  const { text, detail } = serverError(message);
  return say(prefix ? `${prefix}: ${text}` : text, "error", detail);
}

/** A click handler that reports its failure instead of leaving an unhandled rejection. */
export function act(what, fn) {
  return async (event) => {
    try {
      await fn(event);
    } catch (error) {
      if (error.reported) return;
      const prefix = typeof what === "function" ? what() : what;
      if (error instanceof InputProblem)
        say(`${prefix}: ${error.message}`, "error"); // the page's own words, already in its language
      else sayError(prefix, error.message);
    }
  };
}

/** A request to the link; its failure is said once, in the page's language. */
export async function ask(op, args) {
  if (!dashboard.link) throw Object.assign(new Error(t("err.notConnected")), { reported: false });
  if (COMMANDS.has(op)) emit("command", { op, id: args?.id });
  try {
    return await dashboard.link.request(op, args);
  } catch (error) {
    sayError(t(`op.${op}`), error.message);
    error.reported = true;
    throw error;
  } finally {
    if (COMMANDS.has(op)) emit("command-done", { op, id: args?.id });
  }
}
