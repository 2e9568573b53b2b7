import { describe, expect, it } from "vitest";
import { decode } from "../src/codec.js";
import { EncodeError } from "../src/errors.js";
import { fromHex, toHex } from "../src/frame.js";
import {
  decodeIn,
  encodeIn,
  LINE_NAMES,
  lineMessageSpec,
  lineParser,
  lineRecord,
  makeIn,
  UnknownLineError,
} from "../src/lines.js";

describe("product lines", () => {
  it("reads one frame as a different message per line", () => {
    const frame = fromHex("fffe0004e809000a"); // 09: MC rated speed, RSA ratio, SM factory reset (no data)
    expect(decode(frame)).toEqual({ name: "set_rated_speed", id: 0, rated_speed: 10 });
    expect(lineRecord("rsa", decodeIn("rsa", frame))).toEqual({ id: 0, message: "set_ratio", ratio: 10 });
    expect(() => decodeIn("sm", frame)).toThrow(/factory_reset \(mode 09\) has size 2/);
  });

  it("builds frames from the vendor's SM C# layout, and refuses what a line lacks", () => {
    const run = makeIn("sm-cs", "accel_speed", 0, { direction: 0, speed: 1000, arrival_time: 1 });
    expect(toHex(encodeIn("sm-cs", run))).toBe("fffe00060c010003e801");
    expect(() => makeIn("sm", "accel_speed", 0, { direction: 0, speed: 1000, arrival_time: 1 })).toThrow(
      /SM has no message "accel_speed" \(it is a message of mc, rsa, rsavw, sa, sm-cs, sm-readme\)/,
    );
    expect(() => encodeIn("mc", run)).toThrow(EncodeError);
    expect(() => lineMessageSpec("rsa", "set_rated_speed")).toThrow(EncodeError);
    expect(() => makeIn("warp", "request_ping", 0, {})).toThrow(UnknownLineError);
  });

  it("parses a stream in a line's table", () => {
    const ratio = encodeIn("sm", makeIn("sm", "ratio", 9, { ratio: 10 })); // D4, 4 bytes: an SM's ratio
    const parser = lineParser("sm");
    const got = [...parser.feed(ratio.subarray(0, 5)), ...parser.feed(ratio.subarray(5))];
    expect(got.map((m) => lineRecord("sm", m))).toEqual([{ id: 9, message: "ratio", ratio: 10 }]);
    expect(LINE_NAMES).toEqual(["mc", "rsa", "rsavw", "sa", "sm", "sm-cs", "sm-readme"]);
  });
});
