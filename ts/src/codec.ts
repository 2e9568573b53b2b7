/** Build, encode and decode whole frames (sans-I/O: bytes in, typed messages out). */
import { DecodeError, EncodeError, FieldRangeError } from "./errors.js";
import {
  buildFrame,
  CHECKSUM_OFFSET,
  DATA_OFFSET,
  expectedChecksum,
  HEADER_0,
  HEADER_1,
  ID_OFFSET,
  MODE_OFFSET,
  SIZE_OFFSET,
} from "./frame.js";
import type { AnswerOf, MessageFieldMap, MessageName } from "./generated/messages.js";
import { MESSAGE_NAMES } from "./generated/messages.js";
import { BROADCAST_ID, MIN_FRAME_LENGTH, SPECS } from "./generated/tables.js";
import type { FieldSpec, MessageSpec } from "./schema.js";
import { describeRange, fromWire } from "./units.js";

/** One message: its name, controller ID and field values as raw wire integers. */
export type MessageOf<N extends MessageName> = { readonly name: N; readonly id: number } & Readonly<MessageFieldMap[N]>;
/** Any message (a union discriminated by `name`). */
export type Message = { [N in MessageName]: MessageOf<N> }[MessageName];
/** The answer message type of request N. */
export type AnswerMessageOf<N extends keyof AnswerOf> = MessageOf<AnswerOf[N]>;

/** Every message spec by mode byte. */
export const BY_MODE: ReadonlyMap<number, MessageSpec> = new Map(MESSAGE_NAMES.map((n) => [SPECS[n].mode, SPECS[n]]));

export function isMessageName(name: unknown): name is MessageName {
  return typeof name === "string" && Object.hasOwn(SPECS, name);
}

/** The spec of a message by its canonical name, or an `unknown_message` error listing the names. */
export function messageSpec(name: string): MessageSpec {
  if (!isMessageName(name)) {
    throw new EncodeError(
      "unknown_message",
      `unknown message ${JSON.stringify(name)}; known messages: ${MESSAGE_NAMES.join(", ")}`,
      name,
    );
  }
  return SPECS[name];
}

const isInteger = (value: unknown): value is number => typeof value === "number" && Number.isInteger(value);

function checkId(spec: MessageSpec, id: unknown): number {
  if (!isInteger(id))
    throw new EncodeError("type", `${spec.name}.id = ${JSON.stringify(id)} is not an integer`, spec.name, "id");
  if (id < 0 || id > spec.maxId) {
    throw new FieldRangeError(
      spec.name,
      "id",
      id,
      spec.maxId === BROADCAST_ID ? "0..255 (255 = broadcast)" : "0..254 (no broadcast)",
    );
  }
  return id;
}

function checkValue(spec: MessageSpec, field: FieldSpec, value: unknown): number {
  if (!isInteger(value)) {
    throw new EncodeError(
      "type",
      `${spec.name}.${field.name} = ${JSON.stringify(value)} is not an integer wire value; allowed: ${describeRange(field)}`,
      spec.name,
      field.name,
    );
  }
  if (value < field.min || value > field.max)
    throw new FieldRangeError(spec.name, field.name, value, describeRange(field));
  return value;
}

/** Field values of a message by name (a message is a plain object). */
const fieldValue = (message: Message, field: string): unknown => (message as unknown as Record<string, unknown>)[field];

/**
 * Build a message by its canonical name, fully checked: missing and unknown fields,
 * then the ID, then every field in wire order (integer, in range). The first problem
 * throws an EncodeError naming message, field, value, allowed range and unit.
 */
export function make<N extends MessageName>(name: N, id: number, fields: MessageFieldMap[N]): MessageOf<N>;
export function make(name: string, id: unknown, fields: Readonly<Record<string, unknown>>): Message;
export function make(name: string, id: unknown, fields: Readonly<Record<string, unknown>>): Message {
  return makeFromSpec(messageSpec(name), id, fields);
}

/** make() with a given spec (a product line's message, src/lines.ts). */
export function makeFromSpec(spec: MessageSpec, id: unknown, fields: Readonly<Record<string, unknown>>): Message {
  const name = spec.name;
  const wanted = spec.fields.map((f) => f.name);
  const listing = `(fields: ${wanted.join(", ") || "none"})`;
  for (const field of wanted) {
    if (!Object.hasOwn(fields, field)) {
      throw new EncodeError(
        "missing_field",
        `${name} needs the field ${JSON.stringify(field)} ${listing}`,
        name,
        field,
      );
    }
  }
  for (const field of Object.keys(fields)) {
    if (!wanted.includes(field)) {
      throw new EncodeError("unknown_field", `${name} has no field ${JSON.stringify(field)} ${listing}`, name, field);
    }
  }
  const out: Record<string, unknown> = { name: spec.name, id: checkId(spec, id) };
  for (const field of spec.fields) out[field.name] = checkValue(spec, field, fields[field.name]);
  return out as unknown as Message;
}

/** The whole frame of a message; throws EncodeError if the ID or a field is not a valid wire value. */
export function encode(message: Message): Uint8Array {
  return encodeWithSpec(messageSpec(message.name), message);
}

/** encode() with a given spec (a product line's message, src/lines.ts). */
export function encodeWithSpec(spec: MessageSpec, message: Message): Uint8Array {
  const id = checkId(spec, message.id);
  const data = new Uint8Array(spec.size - 2);
  let at = 0;
  for (const field of spec.fields) {
    const value = checkValue(spec, field, fieldValue(message, field.name));
    if (field.width === 2) data[at++] = value >> 8;
    data[at++] = value & 0xff;
  }
  return buildFrame(id, spec.mode, data);
}

const hexByte = (b: number | undefined): string => (b ?? 0).toString(16).padStart(2, "0").toUpperCase();

/**
 * Exactly one whole frame -> its message. Out-of-range field values decode as they are.
 * Throws DecodeError whose kind is the first failing check, in this order:
 * header, truncated, trailing, checksum, unknown_mode, size.
 */
export function decode(frame: Uint8Array): Message {
  return decodeWithModes(frame, BY_MODE);
}

/** decode() with a given mode table (a product line's, src/lines.ts). */
export function decodeWithModes(frame: Uint8Array, byMode: ReadonlyMap<number, MessageSpec>): Message {
  const head = frame.subarray(0, 2);
  if ((head.length > 0 && head[0] !== HEADER_0) || (head.length > 1 && head[1] !== HEADER_1)) {
    throw new DecodeError("header", `frame must start with FF FE, got ${[...head].map(hexByte).join(" ")}`);
  }
  const size = frame[SIZE_OFFSET];
  if (size === undefined || frame.length < MIN_FRAME_LENGTH || frame.length < size + 4) {
    throw new DecodeError(
      "truncated",
      `frame is truncated (${frame.length} bytes${size === undefined ? "" : `, size byte says ${size + 4}`})`,
    );
  }
  if (frame.length > size + 4) {
    throw new DecodeError("trailing", `${frame.length - size - 4} bytes after the frame (size byte says ${size})`);
  }
  const expected = expectedChecksum(frame, 0, frame.length);
  if (frame[CHECKSUM_OFFSET] !== expected) {
    throw new DecodeError(
      "checksum",
      `checksum is ${hexByte(frame[CHECKSUM_OFFSET])}, the bytes give ${hexByte(expected)}`,
    );
  }
  const spec = byMode.get(frame[MODE_OFFSET] ?? -1);
  if (spec === undefined) throw new DecodeError("unknown_mode", `unknown mode ${hexByte(frame[MODE_OFFSET])}`);
  if (size !== spec.size) {
    throw new DecodeError(
      "size",
      `${spec.name} (mode ${hexByte(spec.mode)}) has size ${spec.size}, frame says ${size}`,
    );
  }
  return decodeValid(spec, frame, 0);
}

/** Decode a frame already checked (by decode or the stream parser); no checks repeated. */
export function decodeValid(spec: MessageSpec, buf: Uint8Array, start: number): Message {
  const out: Record<string, unknown> = { name: spec.name, id: buf[start + ID_OFFSET] };
  let at = start + DATA_OFFSET;
  for (const field of spec.fields) {
    out[field.name] = field.width === 2 ? ((buf[at] ?? 0) << 8) | (buf[at + 1] ?? 0) : (buf[at] ?? 0);
    at += field.width;
  }
  return out as unknown as Message;
}

/** Field values as raw wire integers, in wire order. */
export function fieldsOf(message: Message): Record<string, number> {
  const out: Record<string, number> = {};
  for (const field of messageSpec(message.name).fields) out[field.name] = fieldValue(message, field.name) as number;
  return out;
}

/** The conformance form: {"id": .., "message": .., <fields>}. */
export function toRecord(message: Message): Record<string, number | string> {
  return { id: message.id, message: message.name, ...fieldsOf(message) };
}

/** Field values in physical units (degrees, RPM, A, s, us, ratio) or value names ("cw", "off"). */
export function physical(message: Message): Record<string, number | string> {
  const out: Record<string, number | string> = {};
  for (const field of messageSpec(message.name).fields) {
    const raw = fieldValue(message, field.name) as number;
    const named = field.values[raw];
    out[field.name] = named ?? (field.unit !== "" ? fromWire(raw, field.scale) : raw);
  }
  return out;
}

/** The answer name of a request (answer mode = request mode + 0x30); an error for anything else. */
export function answerName<N extends keyof AnswerOf>(request: N): AnswerOf[N];
export function answerName(request: string): MessageName;
export function answerName(request: string): MessageName {
  const answer = messageSpec(request).answer;
  if (answer === null || !isMessageName(answer)) {
    throw new EncodeError("unknown_message", `${request} is not a request; commands are never answered`, request);
  }
  return answer;
}
