// The page's side of the websocket: requests with replies, and live events from the server.
export class ServerLink {
  constructor(url) {
    this.url = url;
    this.next = 1;
    this.pending = new Map();
    this.handlers = new Map();
  }

  connect() {
    return new Promise((resolve, reject) => {
      const ws = new WebSocket(this.url);
      this.ws = ws;
      ws.onopen = () => resolve(this);
      ws.onerror = () => reject(new Error("cannot reach the console server (is `nurimc dashboard` running?)"));
      ws.onclose = (event) => {
        for (const { reject: fail } of this.pending.values()) fail(new Error("connection to the server closed"));
        this.pending.clear();
        this.emit("closed", { code: event.code, reason: event.reason });
      };
      ws.onmessage = (event) => this.receive(JSON.parse(event.data));
    });
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
    this.emit(message.type, message);
  }

  request(op, args = {}) {
    const req = this.next++;
    return new Promise((resolve, reject) => {
      this.pending.set(req, { resolve, reject });
      this.ws.send(JSON.stringify({ op, req, ...args }));
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
