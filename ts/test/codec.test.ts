import fc from "fast-check";
import { describe, expect, it } from "vitest";
import { decode, encode, type Message, make, messageSpec, physical, toRecord } from "../src/codec.js";
import { DecodeError, EncodeError, FieldRangeError } from "../src/errors.js";
import { fromHex, toHex } from "../src/frame.js";
import { MESSAGE_NAMES } from "../src/generated/messages.js";
import { SPECS } from "../src/generated/tables.js";

/** A valid message of `name` with random in-range fields. */
const arbitraryMessage = (name: (typeof MESSAGE_NAMES)[number]): fc.Arbitrary<Message> => {
  const spec = SPECS[name];
  const fields = Object.fromEntries(spec.fields.map((f) => [f.name, fc.integer({ min: f.min, max: f.max })]));
  return fc
    .record({ id: fc.integer({ min: 0, max: spec.maxId }), fields: fc.record(fields) })
    .map(({ id, fields: f }) => make(name as string, id, f));
};
const anyMessage = fc.constantFrom(...MESSAGE_NAMES).chain(arbitraryMessage);

describe("encode and decode", () => {
  it("encodes the document's §1 example and decodes it back", () => {
    const message = make("position_speed", 0, { direction: 0, position: 18000, speed: 1000 });
    expect(toHex(encode(message))).toBe("fffe0007760100465003e8");
    expect(decode(fromHex("fffe0007760100465003e8"))).toEqual(message);
    expect(physical(message)).toEqual({ direction: "ccw", position: 180, speed: 100 });
  });

  it("round-trips every message with any in-range fields", () => {
    fc.assert(
      fc.property(anyMessage, (message) => {
        const frame = encode(message);
        expect(frame.length).toBe(messageSpec(message.name).size + 4);
        expect(decode(frame)).toEqual(message);
      }),
      { numRuns: 2000 },
    );
  });

  it("has all 42 message types of the spec, with distinct modes", () => {
    expect(MESSAGE_NAMES).toHaveLength(42);
    expect(new Set(MESSAGE_NAMES.map((n) => SPECS[n].mode)).size).toBe(42);
  });

  it("names message, field, value, range and unit in a range error", () => {
    const attempt = () => make("position_speed", 0, { direction: 0, position: 18000, speed: 0 });
    expect(attempt).toThrow(FieldRangeError);
    expect(attempt).toThrow("position_speed.speed = 0 is out of range; allowed: 1..65533 (0.1..6553.3 rpm)");
  });

  it("refuses broadcast requests and out-of-range IDs", () => {
    expect(() => make("request_ping", 255, {})).toThrow(
      "request_ping.id = 255 is out of range; allowed: 0..254 (no broadcast)",
    );
    expect(toHex(encode(make("factory_reset", 255, {})))).toBe("fffeff02ee10");
    expect(() => make("factory_reset", 256, {})).toThrow(/0\.\.255 \(255 = broadcast\)/);
  });

  it("reports missing, unknown and mistyped fields in that order", () => {
    const kind = (f: () => unknown): [string, string | null] => {
      try {
        f();
      } catch (err) {
        if (err instanceof EncodeError) return [err.kind, err.field];
      }
      return ["none", null];
    };
    expect(kind(() => make("set_id", 0, {}))).toEqual(["missing_field", "new_id"]);
    expect(kind(() => make("set_id", 0, { new_id: 1, speed: 3 }))).toEqual(["unknown_field", "speed"]);
    expect(kind(() => make("set_id", 0, { new_id: 1.5 }))).toEqual(["type", "new_id"]);
    expect(kind(() => make("set_id", "0", { new_id: 1 }))).toEqual(["type", "id"]);
    expect(kind(() => make("teleport", 0, {}))).toEqual(["unknown_message", null]);
  });

  it("checks a message changed after make when encoding it", () => {
    const message = { ...make("set_baud", 0, { baud_index: 6 }), baud_index: 18 };
    expect(() => encode(message)).toThrow("set_baud.baud_index = 18 is out of range; allowed: 0..17");
  });

  it("decodes out-of-range values as they are", () => {
    const frame = encode(make("position_gains", 1, { kp: 1, ki: 0, kd: 0, rated_current: 1 }));
    frame[6] = 0; // kp 0 is below range
    frame[4] = (frame[4]! + 1) & 0xff;
    expect(toRecord(decode(frame))).toEqual({
      id: 1,
      message: "position_gains",
      kp: 0,
      ki: 0,
      kd: 0,
      rated_current: 1,
    });
  });

  it.each([
    ["00", "header"],
    ["fffd00025da0", "header"],
    ["fffe0002", "truncated"],
    ["fffe00075da0", "truncated"],
    ["fffe00025da000", "trailing"],
    ["fffe00025ca0", "checksum"],
    ["fffe00021ce1", "unknown_mode"],
    ["fffe0003ec0f01", "size"],
  ])("decode %s -> %s error", (hex, kind) => {
    expect(() => decode(fromHex(hex))).toThrow(DecodeError);
    try {
      decode(fromHex(hex));
    } catch (err) {
      expect((err as DecodeError).kind).toBe(kind);
    }
  });

  it("never throws anything but DecodeError on arbitrary bytes", () => {
    fc.assert(
      fc.property(fc.uint8Array({ maxLength: 16 }), (bytes) => {
        try {
          decode(bytes);
        } catch (err) {
          expect(err).toBeInstanceOf(DecodeError);
        }
      }),
      { numRuns: 3000 },
    );
  });

  it("rejects malformed hex with a clear error", () => {
    expect(() => fromHex("ff fe")).toThrow(/not hex/);
    expect(() => fromHex("fff")).toThrow(RangeError);
    expect(fromHex("FFfe")).toEqual(new Uint8Array([0xff, 0xfe]));
  });
});
