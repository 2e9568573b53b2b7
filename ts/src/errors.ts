/** Errors of the protocol layer. Each says what was wrong and what to do. */

/** Base class of every error raised by the protocol layer. */
export class ProtocolError extends Error {
  override name = "ProtocolError";
}

export type EncodeErrorKind = "unknown_message" | "missing_field" | "unknown_field" | "type" | "range" | "wrong_line";

/** A message could not be built or encoded. `kind` is the conformance error name. */
export class EncodeError extends ProtocolError {
  override name = "EncodeError";
  constructor(
    readonly kind: EncodeErrorKind,
    text: string,
    /** the message name, when known */
    readonly messageName: string | null = null,
    /** the offending field (may be "id" or "message"), when there is one */
    readonly field: string | null = null,
  ) {
    super(text);
  }
}

/** A field value outside its allowed range; names message, field, value, range and unit. */
export class FieldRangeError extends EncodeError {
  override name = "FieldRangeError";
  constructor(
    messageName: string,
    field: string,
    readonly value: number,
    /** e.g. "1..65533 (0.1..6553.3 rpm)" */
    readonly allowed: string,
  ) {
    super("range", `${messageName}.${field} = ${value} is out of range; allowed: ${allowed}`, messageName, field);
  }
}

/** The order in which decode checks a frame; the first failing check names the error. */
export const DECODE_ERROR_KINDS = ["header", "truncated", "trailing", "checksum", "unknown_mode", "size"] as const;
export type DecodeErrorKind = (typeof DECODE_ERROR_KINDS)[number];

/** Bytes that are not one valid frame. */
export class DecodeError extends ProtocolError {
  override name = "DecodeError";
  constructor(
    readonly kind: DecodeErrorKind,
    text: string,
  ) {
    super(text);
  }
}
