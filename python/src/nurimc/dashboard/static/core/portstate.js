// The server's bus port as the page shows it (pure): folded from `hello`'s port_state and the
// server's `port` messages (docs/dashboard.md, "Port lost, and floods"). Times are seconds on
// the page's clock; the server's own "down N s" is used only for a page that came in during
// an outage, so its banner counts from the loss and not from when the page was opened.

/** Seconds the server says the port has been down, from its message ("… (down 4.2 s) …"), or null. */
export function downFor(message) {
  const match = /\(down (\d+(?:\.\d+)?) s\)/.exec(String(message ?? ""));
  return match ? Number(match[1]) : null;
}

/** The page's start: nothing known, the port taken as up. */
export const PORT_UP = Object.freeze({ phase: "up", port: "", lostAt: null, downFor: null, stopPending: false });

/**
 * The next port state from a message: `hello` (with port_state) or `port` (state lost | back |
 * resumed | opened | closed). phase: "up" | "lost" | "back" (reopened, motors being read again).
 */
export function nextPortState(state, message, now) {
  if (message.type === "hello") {
    const s = message.port_state;
    if (!s) return state;
    const port = s.port ?? message.port ?? state.port;
    if (s.up) return { ...PORT_UP, port, stopPending: Boolean(s.stop_pending) };
    const down = downFor(s.message);
    const lostAt = state.phase === "lost" && state.lostAt != null ? state.lostAt : now - (down ?? 0);
    return { phase: "lost", port, lostAt, downFor: null, stopPending: Boolean(s.stop_pending) };
  }
  if (message.type !== "port") return state;
  const port = message.port ?? state.port;
  const stopPending = Boolean(message.stop_pending);
  switch (message.state) {
    case "lost":
    case "closed":
      return {
        phase: "lost",
        port,
        lostAt: state.phase === "lost" && state.lostAt != null ? state.lostAt : now - (downFor(message.message) ?? 0),
        downFor: null,
        stopPending,
      };
    case "back": {
      const measured = state.lostAt != null ? now - state.lostAt : null;
      return { phase: "back", port, lostAt: state.lostAt, downFor: measured ?? message.down_for ?? null, stopPending };
    }
    case "resumed":
    case "opened":
      return { ...PORT_UP, port, downFor: state.downFor, stopPending };
    default:
      return state;
  }
}

/** What the port banner says: [catalog key, params], or null when the port is up. */
export function portBanner(state, now) {
  if (state.phase === "lost")
    return ["port.lost", { port: state.port || "?", s: Math.max(0, Math.floor(now - (state.lostAt ?? now))) }];
  if (state.phase === "back") return ["port.back", { port: state.port || "?", s: (state.downFor ?? 0).toFixed(1) }];
  return null;
}
