// The Web Serial bridge's RFC 2217 reader (e2e/serial-bridge.mjs): data with 0xFF doubled,
// the server's SET-BAUDRATE answer, options the bridge did not ask for refused.
import assert from "node:assert/strict";
import { test } from "node:test";
import { telnetReader } from "../serial-bridge.mjs";

function reader() {
  const got = { data: [], subs: [], replies: [] };
  const read = telnetReader(
    (d) => got.data.push(...d),
    (s) => got.subs.push(s),
    (r) => got.replies.push(r),
  );
  return { got, read };
}

test("doubled 0xFF is one data byte, even split across chunks", () => {
  const { got, read } = reader();
  read([0xff]);
  read([0xff, 0xfe, 0x03, 0x02]);
  assert.deepEqual(got.data, [0xff, 0xfe, 0x03, 0x02]);
  assert.deepEqual(got.subs, []);
});

test("the SET-BAUDRATE answer is a subnegotiation, not data", () => {
  const { got, read } = reader();
  read([0x01, 255, 250, 44, 101, 0, 3, 0xd0, 0x90, 255, 240, 0x02]);
  assert.deepEqual(got.subs, [[44, 101, 0, 3, 0xd0, 0x90]]);
  assert.deepEqual(got.data, [0x01, 0x02]);
});

test("an option the bridge did not ask for is refused; COM-PORT-OPTION is not", () => {
  const { got, read } = reader();
  read([255, 251, 1, 255, 253, 24, 255, 253, 44]);
  assert.deepEqual(got.replies, [
    [255, 254, 1],
    [255, 252, 24],
  ]);
});
