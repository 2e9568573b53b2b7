// The page's side of the websocket: requests with replies, live events, and reconnection.
// Every request carries the emergency-stop generation the page has seen ("gen"), so the server
// refuses anything the page sent before a stop it had not yet heard of.
const BACKOFF_MS = [250, 500, 1000, 2000, 4000]; // then every 4 s
const SILENCE_MS = 3000; // the server ticks every second: this long without a word and it is gone (hung, cut off)
const CONNECT_MS = 4000; // a connection attempt that has not opened by then is given up and retried

export class ServerLink {
  constructor(url) {
    this.url = url;
    this.next = 1;
    this.pending = new Map();
    this.handlers = new Map();
    this.connected = false;
    this.generation = 0;
    this.attempt = 0;
    this.retryAt = null;
  }

  /** Connect, and keep reconnecting with backoff whenever the connection is lost. */
  start() {
    this.open();
    return this;
  }

  open() {
    let ws;
    try {
      ws = new WebSocket(this.url);
    } catch {
      this.scheduleRetry();
      return;
    }
    this.ws = ws;
    const giveUp = setTimeout(
      () => this.lost(ws, { code: 0, reason: "no answer to the connection attempt" }),
      CONNECT_MS,
    );
    ws.onopen = () => {
      clearTimeout(giveUp);
      this.connected = true;
      this.attempt = 0;
      this.retryAt = null;
      this.lastHeard = Date.now();
      clearInterval(this.watchdog);
      this.watchdog = setInterval(() => {
        if (Date.now() - this.lastHeard > SILENCE_MS)
          this.lost(ws, { code: 0, reason: `no word from the server for ${SILENCE_MS / 1000} s` });
      }, 250);
    };
    ws.onclose = (event) => {
      clearTimeout(giveUp);
      this.lost(ws, event);
    };
    ws.onerror = () => {}; // onclose follows and says it
    ws.onmessage = (event) => {
      this.lastHeard = Date.now();
      let message;
      try {
        message = JSON.parse(event.data);
      } catch {
        return;
      }
      this.receive(message);
    };
  }

  /** The connection is gone (closed, or silent too long): fail what waits on it, say so, retry. */
  lost(ws, { code, reason }) {
    if (ws !== this.ws) return; // an older connection, already dealt with
    this.ws = null;
    clearInterval(this.watchdog);
    ws.onclose = ws.onmessage = ws.onopen = null;
    try {
      ws.close();
    } catch {
      /* already closing */
    }
    const was = this.connected;
    this.connected = false;
    for (const { reject } of this.pending.values())
      reject(new Error("the connection to the server was lost; the command may not have run"));
    this.pending.clear();
    this.emit("closed", { code, reason, was });
    this.scheduleRetry();
  }

  scheduleRetry() {
    const delay = BACKOFF_MS[Math.min(this.attempt, BACKOFF_MS.length - 1)];
    this.attempt += 1;
    this.retryAt = Date.now() + delay;
    this.emit("retrying", { delay, attempt: this.attempt });
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.open(), delay);
  }

  /** Try now instead of waiting for the backoff. */
  retryNow() {
    if (this.connected) return;
    clearTimeout(this.timer);
    if (this.ws) this.lost(this.ws, { code: 0, reason: "retrying now" });
    clearTimeout(this.timer);
    this.open();
  }

  receive(message) {
    if (message.type === "reply") {
      const waiter = this.pending.get(message.req);
      if (!waiter) return;
      this.pending.delete(message.req);
      if (message.ok) waiter.resolve(message.result);
      else waiter.reject(new Error(message.error));
      return;
    }
    if (message.type === "hello") {
      this.generation = message.generation;
      this.emit("open", message);
    }
    // a stop carried out, or latched while the port is lost: either way a new generation
    if ((message.type === "estop" || message.type === "estop_pending") && message.generation > this.generation)
      this.generation = message.generation;
    this.emit(message.type, message);
  }

  request(op, args = {}) {
    if (!this.connected || this.ws?.readyState !== WebSocket.OPEN) {
      return Promise.reject(new Error("server unreachable: nothing was sent"));
    }
    const req = this.next++;
    const message = op === "estop" ? { op, req } : { op, req, gen: this.generation, ...args };
    return new Promise((resolve, reject) => {
      this.pending.set(req, { resolve, reject });
      this.ws.send(JSON.stringify(message));
    }).then((result) => {
      if (op === "estop" && result.generation > this.generation) this.generation = result.generation;
      return result;
    });
  }

  on(type, handler) {
    if (!this.handlers.has(type)) this.handlers.set(type, []);
    this.handlers.get(type).push(handler);
  }

  emit(type, message) {
    for (const handler of this.handlers.get(type) ?? []) handler(message);
  }
}
