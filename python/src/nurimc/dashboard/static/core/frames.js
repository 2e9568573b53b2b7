// Raw frames (pure): which are the console's own polling, the filters, and the traffic log that
// `nurimc replay` reads ({"t": seconds, "dir": "tx"|"rx", "hex": "..."} per line).

/** The console reads each watched motor's state continuously with these two messages. */
export const POLLING = new Set(["request_position", "position_feedback"]);
export const isPolling = (frame) => POLLING.has(frame.name);

/**
 * Frames passing the filters: { id: "1" | "", message: "" | name, dir: "" | "tx" | "rx",
 * search: free text (matched in the name, fields and bytes), polling: show the console's own }.
 */
export function filterFrames(frames, { id = "", message = "", dir = "", search = "", polling = false } = {}) {
  const ids = String(id)
    .split(/[\s,]+/)
    .filter(Boolean);
  const terms = String(search).toLowerCase().split(/\s+/).filter(Boolean);
  return frames.filter((f) => {
    if (!polling && isPolling(f)) return false;
    if (ids.length && !ids.includes(String(f.id))) return false;
    if (message && f.name !== message) return false;
    if (dir && f.dir !== dir) return false;
    if (terms.length) {
      const text = `${f.name ?? ""} ${JSON.stringify(f.fields ?? {})} ${f.hex ?? ""}`.toLowerCase();
      if (!terms.every((term) => text.includes(term))) return false;
    }
    return true;
  });
}

/** A traffic log (JSON lines) of these frames; frames without bytes (noise markers) are left out. */
export function trafficLog(frames) {
  return frames
    .filter((f) => f.hex && (f.dir === "tx" || f.dir === "rx"))
    .map((f) => JSON.stringify({ t: Math.max(0, f.t), dir: f.dir, hex: f.hex.replace(/\s+/g, "") }))
    .join("\n")
    .concat("\n");
}
