/**
 * Product lines (spec/lines.json): the same frame, a different message table per line.
 * A message of a line carries `line`; a line's messages are built, encoded, decoded and
 * parsed with that line's table only, so an RSA `set_ratio` (mode 09) can never be sent as
 * MC's (mode 0B). See docs/protocol.md, Product lines.
 */
import { decodeWithModes, encodeWithSpec, type Message, makeFromSpec } from "./codec.js";
import { EncodeError } from "./errors.js";
import { LINES } from "./generated/lines.js";
import { StreamParser } from "./parser.js";
import type { LineSpec, MessageSpec } from "./schema.js";

/** A line name spec/lines.json does not have. */
export class UnknownLineError extends Error {
  readonly kind = "unknown_line";
}

/** A message of one line with its line's name; field values are raw wire integers. */
export type LineMessage = Message & { readonly line: string };

interface LineTables {
  readonly spec: LineSpec;
  readonly byName: ReadonlyMap<string, MessageSpec>;
  readonly byMode: ReadonlyMap<number, MessageSpec>;
  readonly specOfMode: readonly (MessageSpec | undefined)[];
}

const TABLES = new Map<string, LineTables>();
for (const [key, spec] of Object.entries(LINES)) {
  const byMode = new Map(spec.messages.map((m) => [m.mode, m]));
  TABLES.set(key, {
    spec,
    byName: new Map(spec.messages.map((m) => [m.name, m])),
    byMode,
    specOfMode: Array.from({ length: 256 }, (_, mode) => byMode.get(mode)),
  });
}

/** Every line's key: mc, rsa, rsavw, sa, sm, sm-cs, sm-readme. */
export const LINE_NAMES: readonly string[] = [...TABLES.keys()];

function tables(line: unknown): LineTables {
  const found = typeof line === "string" ? TABLES.get(line) : undefined;
  if (found === undefined) {
    throw new UnknownLineError(`unknown product line ${JSON.stringify(line)}; lines: ${LINE_NAMES.join(", ")}`);
  }
  return found;
}

/** The spec of a line (UnknownLineError if there is none of that name). */
export const lineSpec = (line: unknown): LineSpec => tables(line).spec;

/** The spec of a line's message by name, or an `unknown_message` error naming the lines that have it. */
export function lineMessageSpec(line: string, name: unknown): MessageSpec {
  const t = tables(line);
  const spec = typeof name === "string" ? t.byName.get(name) : undefined;
  if (spec === undefined) {
    const others = LINE_NAMES.filter((key) => typeof name === "string" && tables(key).byName.has(name));
    const where = others.length > 0 ? ` (it is a message of ${others.join(", ")})` : "";
    throw new EncodeError(
      "unknown_message",
      `${t.spec.title} has no message ${JSON.stringify(name)}${where}; ${t.spec.title} messages: ${[...t.byName.keys()].join(", ")}`,
      String(name),
    );
  }
  return spec;
}

const withLine = (line: string, message: Message): LineMessage => ({ ...message, line }) as LineMessage;

/** Build a line's message by name, fully checked like make(). */
export function makeIn(
  line: string,
  name: string,
  id: unknown,
  fields: Readonly<Record<string, unknown>>,
): LineMessage {
  return withLine(line, makeFromSpec(lineMessageSpec(line, name), id, fields));
}

/** The whole frame of a line's message; refuses a message of another line. */
export function encodeIn(line: string, message: LineMessage): Uint8Array {
  if (message.line !== line) {
    throw new EncodeError(
      "wrong_line",
      `${message.name} of the ${lineSpec(message.line).title} line cannot go to a controller of the ${lineSpec(line).title} line`,
      message.name,
    );
  }
  return encodeWithSpec(lineMessageSpec(line, message.name), message);
}

/** Exactly one whole frame -> the line's message (the checks and order of decode()). */
export function decodeIn(line: string, frame: Uint8Array): LineMessage {
  return withLine(line, decodeWithModes(frame, tables(line).byMode));
}

/** A stream parser reading frames with a line's table. */
export const lineParser = (line: string): StreamParser => new StreamParser(tables(line).specOfMode);

/** The conformance form of a line's message: {"id", "message", <fields>} in wire order. */
export function lineRecord(line: string, message: Message): Record<string, number | string> {
  const out: Record<string, number | string> = { id: message.id, message: message.name };
  const values = message as unknown as Record<string, number>;
  for (const field of lineMessageSpec(line, message.name).fields) out[field.name] = values[field.name] as number;
  return out;
}
