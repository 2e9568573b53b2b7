// The page's state in one place, readable by tests and people alike (window.dashboard), with a
// small event bus so views react to each other without importing each other.
export const dashboard = {
  mode: null, // "server" | "direct"
  link: null,
  connected: false,
  motors: new Map(), // id -> { info, series, plot, card, control, stopped, busy, errors, ... }
  samplesReceived: 0,
  frames: [],
  settings: [],
  lastStep: null,
  stepRuns: [],
  stops: 0, // emergency stops seen by this page: a running sequence ends when this changes
  stopped: false, // an emergency stop happened and no command has been given since (the banner)
  everDiscovered: false,
  boot: null, // the server process the page last talked to (another one: restarted, new clock)
  clockOffset: 0, // server sample time + this = seconds on this page's clock, continuous across restarts
  sequence: [],
  busStats: null, // the server's bus statistics (tick), when it sends them
  errors: 0, // motor errors the page was told about
};

const handlers = new Map();
export function on(type, handler) {
  if (!handlers.has(type)) handlers.set(type, []);
  handlers.get(type).push(handler);
}
export function emit(type, payload) {
  for (const handler of handlers.get(type) ?? []) handler(payload);
}
