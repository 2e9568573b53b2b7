/** Types that describe the protocol: what the generated tables are made of. */

/** command: host -> controller, never answered; request: answered; answer: controller -> host. */
export type Kind = "command" | "request" | "answer";

/** One field on the wire: its width, allowed range and physical unit. */
export interface FieldSpec {
  readonly name: string;
  /** bytes, big-endian */
  readonly width: number;
  readonly min: number;
  readonly max: number;
  /** "deg", "rpm", "A", "s", "us", "ratio", "count" or "" (no unit) */
  readonly unit: string;
  /** physical value = wire value * scale */
  readonly scale: number;
  /** names of enumerated values, e.g. {0: "ccw", 1: "cw"} */
  readonly values: Readonly<Record<number, string>>;
  readonly doc: string;
}

/** One message type: mode byte, size byte and fields in wire order. */
export interface MessageSpec {
  readonly name: string;
  readonly kind: Kind;
  readonly mode: number;
  readonly size: number;
  readonly section: number;
  readonly title: string;
  readonly fields: readonly FieldSpec[];
  /** for requests: the answer's name */
  readonly answer: string | null;
  /** for answers: the request's name */
  readonly request: string | null;
  /** 0xFF (broadcast) is allowed for commands only */
  readonly maxId: number;
}

/** A product line speaking this protocol, with its assumed defaults. */
export interface ProductSpec {
  readonly key: string;
  readonly title: string;
  readonly motor: string;
  readonly resolutionUnit: string;
  readonly maxRatedCurrent: number;
  readonly defaults: Readonly<Record<string, number>>;
}

/** A product line: which message each mode byte means (spec/lines.json). */
export interface LineSpec {
  readonly key: string;
  readonly title: string;
  readonly what: string;
  readonly source: string;
  readonly products: readonly string[];
  readonly messages: readonly MessageSpec[];
}
