import { describe, expect, it } from "vitest";
import { answerLine, LineSplitter } from "../src/conformance.js";
import { MAX_LINE_BYTES } from "../src/jsonline.js";

const enc = new TextEncoder();

function split(chunks: Uint8Array[]): (string | null)[] {
  const out: (string | null)[] = [];
  const splitter = new LineSplitter((line) => out.push(line === null ? null : new TextDecoder().decode(line)));
  for (const chunk of chunks) splitter.push(chunk);
  splitter.end();
  return out;
}

describe("conformance line splitting", () => {
  it("ends lines at LF only, across chunk boundaries, and keeps a last unterminated line", () => {
    const text = 'a\r\n\nb\rc\n{"x"';
    for (let cut = 0; cut <= text.length; cut++) {
      const bytes = enc.encode(text);
      expect(split([bytes.subarray(0, cut), bytes.subarray(cut)])).toEqual(["a\r", "", "b\rc", '{"x"']);
    }
  });

  it("reads past an overlong line, whatever the chunking, and goes on", () => {
    const long = new Uint8Array(MAX_LINE_BYTES + 1).fill(0x20);
    const tail = enc.encode("\nnext\n");
    expect(split([long, tail])).toEqual([null, "next"]);
    expect(split([long.subarray(0, 10), long.subarray(10), tail])).toEqual([null, "next"]);
    const exact = new Uint8Array(MAX_LINE_BYTES).fill(0x41);
    expect(split([exact, tail])[0]).toHaveLength(MAX_LINE_BYTES);
  });

  it("an empty input has no line; a newline alone is one empty line", () => {
    expect(split([])).toEqual([]);
    expect(split([enc.encode("\n")])).toEqual([""]);
  });
});

describe("conformance answers", () => {
  it("tells integers from integer-valued floats by how they are written", () => {
    const line = (kp: string) =>
      enc.encode(`{"op":"encode","id":1,"message":"position_gains","kp":${kp},"ki":0,"kd":0,"rated_current":1}`);
    expect(answerLine(line("2"))).toEqual({ hex: "fffe010622d302000001" });
    expect(answerLine(line("2.0"))).toEqual({ error: "type", field: "kp" });
    expect(answerLine(line("2e0"))).toEqual({ error: "type", field: "kp" });
    expect(answerLine(line("1" + "0".repeat(400)))).toEqual({ error: "range", field: "kp" });
  });

  it("gives bad_request, not an exception, for deep nesting and broken input", () => {
    const deep = enc.encode("[".repeat(100_000) + "]".repeat(100_000));
    expect(answerLine(deep)).toMatchObject({ error: "bad_request" });
    expect(answerLine(enc.encode('{"op":NaN}'))).toMatchObject({ error: "bad_request" });
    expect(answerLine(new Uint8Array([0x7b, 0xff, 0x7d]))).toMatchObject({ error: "bad_request" });
  });
});
