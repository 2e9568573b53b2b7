// Backup / restore: every setting of every motor to the CLI's JSON format and back.
import { $, download } from "../core/dom.js";
import { t } from "../core/i18n.js";
import { InputProblem } from "../core/input.js";
import { dashboard } from "../core/store.js";
import { act, ask } from "./messages.js";

export function startBackup() {
  $("#backup").onclick = act(
    () => t("op.backup"),
    async () => {
      const ids = [...dashboard.motors.keys()];
      if (!ids.length) throw new InputProblem(t("backup.discoverFirst"));
      const document_ = await ask("backup", { ids });
      const text = JSON.stringify(document_, null, 2);
      $("#backup-text").textContent = text;
      download(`nurimc-backup-${document_.time}.json`, text, "application/json");
    },
  );
  $("#restore-file").onchange = act(
    () => t("op.restore"),
    async (event) => {
      const file = event.target.files[0];
      if (!file) return;
      let document_;
      try {
        document_ = JSON.parse(await file.text());
      } catch (error) {
        throw new InputProblem(t("msg.notJson", { name: file.name, why: error.message }));
      }
      const result = await ask("restore", { document: document_, name: file.name });
      $("#backup-text").textContent = result.changed.length
        ? `${t("backup.restored")}\n${result.changed.join("\n")}`
        : t("backup.nothing");
    },
  );
}
