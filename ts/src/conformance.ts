/** The JSON-lines conformance program (conformance/README.md): one answer line per input line. */
import { createInterface } from "node:readline";
import { decode, encode, make, toRecord, type Message } from "./codec.js";
import { DecodeError, EncodeError } from "./errors.js";
import { fromHex } from "./frame.js";
import { StreamParser } from "./parser.js";

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

function parse(request: Record<string, unknown>): Reply {
  const parser = new StreamParser();
  const frames: Message[] = [];
  const chunks = request["chunks"];
  if (chunks === undefined) frames.push(...parser.feed(bytes(request["hex"])));
  else for (const chunk of Array.isArray(chunks) ? (chunks as unknown[]) : [null]) frames.push(...parser.feed(bytes(chunk)));
  frames.push(...parser.finish());
  return { frames: frames.map(toRecord), dropped_bytes: parser.stats.droppedBytes };
}

export function answer(request: unknown): Reply {
  if (typeof request !== "object" || request === null || Array.isArray(request)) {
    return { error: "bad_request", detail: "each line must be a JSON object" };
  }
  const req = request as Record<string, unknown>;
  try {
    switch (req["op"]) {
      case "decode":
        return toRecord(decode(bytes(req["hex"])));
      case "encode": {
        for (const key of ["message", "id"]) if (!(key in req)) return { error: "missing_field", field: key };
        if (typeof req["message"] !== "string") return { error: "unknown_message" };
        const { op: _op, id, message, ...fields } = req;
        return { hex: Buffer.from(encode(make(message as string, id, fields))).toString("hex") };
      }
      case "parse":
        return parse(req);
      default:
        return { error: "unknown_op" };
    }
  } catch (err) {
    if (err instanceof DecodeError) return { error: err.kind };
    if (err instanceof EncodeError) return err.field === null ? { error: err.kind } : { error: err.kind, field: err.field };
    if (err instanceof BadHex) return { error: "bad_hex" };
    throw err;
  }
}

function serve(): void {
  const lines = createInterface({ input: process.stdin, crlfDelay: Infinity });
  lines.on("line", (line) => {
    if (line.trim() === "") return;
    let request: unknown;
    try {
      request = JSON.parse(line);
    } catch (err) {
      process.stdout.write(JSON.stringify({ error: "bad_request", detail: `not JSON: ${String(err)}` }) + "\n");
      return;
    }
    const reply: Reply = answer(request);
    process.stdout.write(JSON.stringify(reply) + "\n");
  });
}

serve();
