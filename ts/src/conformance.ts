/** The JSON-lines conformance program (conformance/README.md): one answer line per input line. */
import { realpathSync } from "node:fs";
import { pathToFileURL } from "node:url";
import { decode, encode, make, toRecord } from "./codec.js";
import { DecodeError, EncodeError } from "./errors.js";
import { fromHex } from "./frame.js";
import { BadRequest, JsonFloat, type JsonValue, MAX_LINE_BYTES, readRequest } from "./jsonline.js";
import { decodeIn, encodeIn, lineParser, lineRecord, lineSpec, makeIn, UnknownLineError } from "./lines.js";
import { SETTINGS, setting, settingFromWire, settingToWire } from "./settings.js";
import { arrivalToWire, fromWire, positionToWire, signedFromWire, speedToWire, UnitRangeError } from "./units.js";

type Reply = Record<string, unknown>;

class BadHex extends Error {}

function bytes(text: unknown): Uint8Array {
  if (typeof text !== "string") throw new BadHex();
  try {
    return fromHex(text);
  } catch {
    throw new BadHex();
  }
}

const own = (object: Record<string, unknown>, key: string): unknown =>
  Object.hasOwn(object, key) ? object[key] : undefined;

/** The request's product line ("line", spec/lines.json); MC when absent. */
function lineOf(request: Record<string, unknown>): string {
  const line = Object.hasOwn(request, "line") ? request.line : "mc";
  return lineSpec(line).key;
}

function parse(request: Record<string, unknown>): Reply {
  const chunks = own(request, "chunks");
  let pieces: Uint8Array[];
  if (chunks === undefined || chunks === null) pieces = [bytes(own(request, "hex"))];
  else if (Array.isArray(chunks)) pieces = chunks.map(bytes);
  else throw new BadHex();
  const line = lineOf(request);
  const parser = lineParser(line);
  const record = line === "mc" ? toRecord : (message: Parameters<typeof toRecord>[0]) => lineRecord(line, message);
  const frames: Reply[] = [];
  // One push per frame: spreading 100,000 frames into push() overflows the call stack.
  for (const piece of pieces) for (const message of parser.feed(piece)) frames.push(record(message));
  for (const message of parser.finish()) frames.push(record(message));
  return { frames, dropped_bytes: parser.stats.droppedBytes };
}

/** The units ops' quantities: the motion ones, then every setting of spec/settings.json by its exact name. */
const MOTION = ["degrees", "rpm", "seconds"];
const QUANTITIES = new Set([...MOTION, ...SETTINGS.map((s) => s.name)]);

class UnitError extends Error {
  constructor(readonly kind: "unknown_quantity" | "type" | "range") {
    super(kind);
  }
}

/** A JSON number as the double every JSON reader makes of it. */
function numberOf(value: unknown): number | null {
  if (value instanceof JsonFloat) return Number(value.text);
  return typeof value === "number" ? value : null;
}

/** A JSON integer (written without fraction or exponent) in 0..max; `type` / `range` otherwise. */
function integerIn(value: unknown, max: number): number {
  if (typeof value !== "number") throw new UnitError("type");
  if (value < 0 || value > max) throw new UnitError("range");
  return value;
}

function quantityOf(req: Record<string, unknown>): string {
  const quantity = own(req, "quantity");
  if (typeof quantity !== "string" || !QUANTITIES.has(quantity)) throw new UnitError("unknown_quantity");
  return quantity;
}

function toWireOp(req: Record<string, unknown>): Reply {
  const quantity = quantityOf(req);
  const value = own(req, "value");
  const spec = MOTION.includes(quantity) ? undefined : setting(quantity);
  const number = numberOf(value);
  if (number === null && !(typeof value === "string" && spec?.input === "choice")) throw new UnitError("type");
  try {
    if (quantity === "degrees") return { ...positionToWire(number as number) };
    if (quantity === "rpm") return { ...speedToWire(number as number) };
    if (quantity === "seconds") return { wire: arrivalToWire(number as number) };
    return { wire: settingToWire(setting(quantity), number ?? (value as string)) };
  } catch (err) {
    if (err instanceof UnitRangeError) throw new UnitError("range");
    throw err;
  }
}

function fromWireOp(req: Record<string, unknown>): Reply {
  const quantity = quantityOf(req);
  const wire = integerIn(own(req, "wire"), 65535);
  if (quantity === "degrees" || quantity === "rpm") {
    const direction = integerIn(own(req, "direction"), 1);
    return { value: signedFromWire(direction, wire, quantity === "degrees" ? 0.01 : 0.1) };
  }
  if (quantity === "seconds") return { value: fromWire(wire, 0.1) };
  return { value: settingFromWire(setting(quantity), wire) };
}

export function answer(request: unknown): Reply {
  // a number written with a fraction or an exponent is read as a JsonFloat object: still no request object
  if (typeof request !== "object" || request === null || Array.isArray(request) || request instanceof JsonFloat) {
    return { error: "bad_request", detail: "each line must be a JSON object" };
  }
  const req = request as Record<string, unknown>;
  try {
    switch (own(req, "op")) {
      case "decode": {
        const line = lineOf(req);
        const frame = bytes(own(req, "hex"));
        return line === "mc" ? toRecord(decode(frame)) : lineRecord(line, decodeIn(line, frame));
      }
      case "encode": {
        const line = lineOf(req);
        for (const key of ["message", "id"])
          if (own(req, key) === undefined) return { error: "missing_field", field: key };
        const message = own(req, "message");
        if (typeof message !== "string") return { error: "unknown_message" };
        const fields = Object.create(null) as Record<string, unknown>;
        for (const key of Object.keys(req))
          if (key !== "op" && key !== "id" && key !== "message" && key !== "line") fields[key] = req[key];
        if (line !== "mc") {
          const frame = encodeIn(line, makeIn(line, message, own(req, "id"), fields));
          return { hex: Buffer.from(frame).toString("hex") };
        }
        return { hex: Buffer.from(encode(make(message, own(req, "id"), fields))).toString("hex") };
      }
      case "parse":
        return parse(req);
      case "to_wire":
        return toWireOp(req);
      case "from_wire":
        return fromWireOp(req);
      default:
        return { error: "unknown_op" };
    }
  } catch (err) {
    if (err instanceof DecodeError) return { error: err.kind };
    if (err instanceof EncodeError)
      return err.field === null ? { error: err.kind } : { error: err.kind, field: err.field };
    if (err instanceof BadHex) return { error: "bad_hex" };
    if (err instanceof UnitError) return { error: err.kind };
    if (err instanceof UnknownLineError) return { error: err.kind };
    throw err;
  }
}

/** The answer to one input line (its bytes without the newline). */
export function answerLine(line: Uint8Array): Reply {
  let request: JsonValue;
  try {
    request = readRequest(line);
  } catch (err) {
    if (err instanceof BadRequest) return { error: "bad_request", detail: err.message };
    throw err;
  }
  return answer(request);
}

/**
 * Splits a byte stream into lines: only LF ends a line, a last unterminated line counts,
 * and a line longer than MAX_LINE_BYTES is read past without being kept (it comes out as null).
 */
export class LineSplitter {
  private parts: Uint8Array[] = [];
  private length = 0;
  private overlong = false;

  constructor(private readonly emit: (line: Uint8Array | null) => void) {}

  push(chunk: Uint8Array): void {
    let start = 0;
    for (;;) {
      const end = chunk.indexOf(0x0a, start);
      const piece = chunk.subarray(start, end < 0 ? chunk.length : end);
      this.add(piece);
      if (end < 0) return;
      this.flush();
      start = end + 1;
    }
  }

  end(): void {
    if (this.length > 0 || this.overlong) this.flush();
  }

  private add(piece: Uint8Array): void {
    if (this.overlong || piece.length === 0) return;
    if (this.length + piece.length > MAX_LINE_BYTES) {
      this.overlong = true;
      this.parts = [];
      this.length = 0;
      return;
    }
    this.parts.push(piece.slice());
    this.length += piece.length;
  }

  private flush(): void {
    if (this.overlong) {
      this.emit(null);
    } else {
      const line = new Uint8Array(this.length);
      let at = 0;
      for (const part of this.parts) {
        line.set(part, at);
        at += part.length;
      }
      this.emit(line);
    }
    this.parts = [];
    this.length = 0;
    this.overlong = false;
  }
}

function serve(): void {
  const splitter = new LineSplitter((line) => {
    const reply: Reply =
      line === null ? { error: "bad_request", detail: `line longer than ${MAX_LINE_BYTES} bytes` } : answerLine(line);
    process.stdout.write(JSON.stringify(reply) + "\n");
  });
  process.stdin.on("data", (chunk: Buffer) => splitter.push(chunk));
  process.stdin.on("end", () => splitter.end());
}

// Serve only when run as the program, not when a test imports the functions above.
const entry = process.argv[1];
if (entry !== undefined && import.meta.url === pathToFileURL(realpathSync(entry)).href) serve();
