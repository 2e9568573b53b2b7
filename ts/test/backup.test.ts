import { readFileSync } from "node:fs";
import { describe, expect, it } from "vitest";
import { BackupError, checkBackup, parseBackup, StorageJournal } from "../src/backup.js";

interface Case {
  name: string;
  text?: string;
  document?: unknown;
  ok?: boolean;
  error?: string;
}
const cases = (
  JSON.parse(readFileSync(new URL("../../spec/vectors/backup-files.json", import.meta.url), "utf8")) as {
    cases: Case[];
  }
).cases;

describe("backup files: the shared vectors (spec/vectors/backup-files.json)", () => {
  for (const c of cases) {
    it(c.name, () => {
      const read = () =>
        c.text !== undefined ? parseBackup(c.text, "robot.json") : checkBackup(c.document, "robot.json");
      if (c.ok) {
        expect(read().format).toBe("nurimc-backup/1");
        return;
      }
      let message = "";
      try {
        read();
      } catch (error) {
        expect(error).toBeInstanceOf(BackupError);
        message = (error as Error).message;
      }
      expect(message).toContain(c.error);
      expect(message).toContain("robot.json");
      expect(message).not.toContain("\n");
    });
  }
});

describe("the restore journal in a Storage", () => {
  it("marks each ID before writing and clears it when done; a mark left behind names the file", () => {
    const store = new Map<string, string>();
    const storage = {
      getItem: (k: string) => store.get(k) ?? null,
      setItem: (k: string, v: string) => void store.set(k, v),
      removeItem: (k: string) => void store.delete(k),
    };
    const journal = new StorageJournal(storage, "port-a");
    journal.begin([1, 2], "robot.json");
    expect(journal.pending(1)).toBe("robot.json");
    journal.done([1]);
    expect(journal.pending(1)).toBeNull();
    expect(new StorageJournal(storage, "port-a").pending(2)).toBe("robot.json"); // survives a reload
    expect(new StorageJournal(storage, "port-b").pending(2)).toBeNull();
    store.set("nurimc.restore.port-a.id3", "{garbled");
    expect(journal.pending(3)).toBeNull();
  });
});
