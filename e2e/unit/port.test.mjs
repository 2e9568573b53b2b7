// The port across an outage (core/portstate.js), the badge while it is lost, and the server's
// outage errors in Korean: pure, no browser.
import assert from "node:assert/strict";
import { join } from "node:path";
import { test } from "node:test";
import { STATIC } from "./paths.mjs";

const { downFor, nextPortState, PORT_UP, portBanner } = await import(join(STATIC, "core/portstate.js"));
const { motorState } = await import(join(STATIC, "core/motorstate.js"));
const { serverError } = await import(join(STATIC, "core/i18n.js"));

const LOST_NOW =
  "port /dev/ttyX is lost ([Errno 5] Input/output error) and being reopened (down 0.0 s); nothing was sent";
const LOST_TEXT =
  "port /dev/ttyX is lost ([Errno 5] Input/output error) and being reopened (down 4.2 s); nothing was sent";

test("lost, back, resumed: the banner counts from the loss and clears on the return", () => {
  const lost = nextPortState(PORT_UP, { type: "port", state: "lost", port: "/dev/ttyX", message: LOST_NOW }, 100);
  assert.equal(lost.phase, "lost");
  assert.deepEqual(portBanner(lost, 103.6), ["port.lost", { port: "/dev/ttyX", s: 3 }]);
  const again = nextPortState(lost, { type: "port", state: "lost", port: "/dev/ttyX", message: LOST_TEXT }, 102);
  assert.equal(again.lostAt, lost.lostAt, "a repeated loss keeps counting from the first");
  const back = nextPortState(
    again,
    { type: "port", state: "back", port: "/dev/ttyX", down_for: 0.05, stop_pending: true },
    105,
  );
  assert.equal(back.phase, "back");
  assert.equal(back.stopPending, true);
  assert.deepEqual(portBanner(back, 105), ["port.back", { port: "/dev/ttyX", s: "5.0" }], "the page's own measure");
  const resumed = nextPortState(
    back,
    { type: "port", state: "resumed", port: "/dev/ttyX", stop_pending: false },
    105.2,
  );
  assert.equal(resumed.phase, "up");
  assert.equal(resumed.stopPending, false);
  assert.equal(portBanner(resumed, 106), null);
  const opened = nextPortState(lost, { type: "port", state: "opened", port: "/dev/ttyY" }, 101);
  assert.deepEqual([opened.phase, opened.port, portBanner(opened, 101)], ["up", "/dev/ttyY", null]);
});

test("a page opened during an outage counts from the server's 'down N s', and sees a latched stop", () => {
  assert.equal(downFor(LOST_TEXT), 4.2);
  assert.equal(downFor("nothing here"), null);
  const hello = {
    type: "hello",
    port: "/dev/ttyX",
    port_state: { port: "/dev/ttyX", up: false, stop_pending: true, message: LOST_TEXT },
  };
  const state = nextPortState(PORT_UP, hello, 50);
  assert.equal(state.phase, "lost");
  assert.equal(state.stopPending, true);
  assert.deepEqual(portBanner(state, 50), ["port.lost", { port: "/dev/ttyX", s: 4 }]);
  const up = nextPortState(
    state,
    { type: "hello", port_state: { port: "/dev/ttyX", up: true, stop_pending: false } },
    60,
  );
  assert.deepEqual([up.phase, up.stopPending], ["up", false]);
  assert.equal(nextPortState(up, { type: "samples" }, 61), up, "other messages change nothing");
});

test("while the port is lost every badge says not answering, even a stopped or busy one", () => {
  const base = { stopped: false, busy: 0, control: "on", lastSampleAt: 10, lastErrorAt: null, speed: 30 };
  assert.equal(motorState(base, 10.1), "moving");
  assert.equal(motorState({ ...base, portDown: true }, 10.1), "silent");
  assert.equal(motorState({ ...base, stopped: true, busy: 1, portDown: true }, 10.1), "silent");
  assert.equal(motorState({ ...base, stopped: true, portDown: false }, 10.1), "stopped");
});

test("the server's outage errors are said in Korean, the original kept", () => {
  for (const [message, key] of [
    [`stop pending: port lost: ${LOST_TEXT}. The stop is latched`, "정지 대기"],
    [LOST_TEXT, "포트가 끊겨"],
    ["cannot reopen /dev/ttyX: not back yet; still retrying in the background", "다시 열 수 없습니다"],
  ]) {
    const { text, detail } = serverError(message, "ko");
    assert.ok(text.includes(key), `${message} -> ${text}`);
    assert.equal(detail, message);
  }
});
