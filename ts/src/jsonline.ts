/**
 * One request line under the conformance line contract (conformance/README.md): strict
 * UTF-8, strict RFC 8259 JSON, integers told from floats by how they are written, at most
 * MAX_DEPTH levels of nesting. JSON.parse cannot do this (it reads `0.0` as the integer 0
 * and knows no depth limit), so this is a small reader of its own.
 */

export const MAX_LINE_BYTES = 4 * 1024 * 1024;
export const MAX_DEPTH = 64;

/** A line that is not one request; the message is the `detail` of the answer. */
export class BadRequest extends Error {}

/** A number written with a fraction or an exponent: never an integer, whatever its value. */
export class JsonFloat {
  constructor(readonly text: string) {}
  toJSON(): string {
    return this.text;
  }
}

export type JsonValue = null | boolean | number | string | JsonFloat | JsonValue[] | { [key: string]: JsonValue };

/** RFC 8259 number syntax, anchored where the reader stands (sticky). */
const NUMBER = /-?(?:0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?/y;

const utf8 = new TextDecoder("utf-8", { fatal: true, ignoreBOM: true });

const isSpace = (c: number): boolean => c === 0x20 || c === 0x09 || c === 0x0a || c === 0x0d;

/** The JSON value of one line (bytes without the newline), or a BadRequest. */
export function readRequest(line: Uint8Array): JsonValue {
  if (line.every((b) => b === 0x20 || b === 0x09 || b === 0x0d)) throw new BadRequest("empty line");
  let text: string;
  try {
    text = utf8.decode(line);
  } catch {
    throw new BadRequest("not UTF-8");
  }
  return new Reader(text).document();
}

class Reader {
  private at = 0;
  constructor(private readonly text: string) {}

  document(): JsonValue {
    const value = this.value(1);
    this.space();
    if (this.at !== this.text.length) this.fail("extra data after the value");
    return value;
  }

  private fail(what: string): never {
    throw new BadRequest(`not JSON: ${what} at character ${this.at}`);
  }

  private space(): void {
    while (this.at < this.text.length && isSpace(this.text.charCodeAt(this.at))) this.at++;
  }

  private value(depth: number): JsonValue {
    this.space();
    const c = this.text[this.at];
    if (c === "{" || c === "[") {
      if (depth > MAX_DEPTH) throw new BadRequest(`nested deeper than ${MAX_DEPTH} levels`);
      return c === "{" ? this.object(depth) : this.array(depth);
    }
    if (c === '"') return this.string();
    if (this.literal("true")) return true;
    if (this.literal("false")) return false;
    if (this.literal("null")) return null;
    return this.number();
  }

  private literal(word: string): boolean {
    if (!this.text.startsWith(word, this.at)) return false;
    this.at += word.length;
    return true;
  }

  private object(depth: number): { [key: string]: JsonValue } {
    // No prototype: "__proto__" and "constructor" are ordinary keys.
    const out = Object.create(null) as { [key: string]: JsonValue };
    this.at++;
    this.space();
    if (this.text[this.at] === "}") {
      this.at++;
      return out;
    }
    for (;;) {
      this.space();
      if (this.text[this.at] !== '"') this.fail("expected a member name");
      const key = this.string();
      this.space();
      if (this.text[this.at] !== ":") this.fail("expected ':'");
      this.at++;
      out[key] = this.value(depth + 1);
      this.space();
      const next = this.text[this.at++];
      if (next === "}") return out;
      if (next !== ",") this.fail("expected ',' or '}'");
    }
  }

  private array(depth: number): JsonValue[] {
    const out: JsonValue[] = [];
    this.at++;
    this.space();
    if (this.text[this.at] === "]") {
      this.at++;
      return out;
    }
    for (;;) {
      out.push(this.value(depth + 1));
      this.space();
      const next = this.text[this.at++];
      if (next === "]") return out;
      if (next !== ",") this.fail("expected ',' or ']'");
    }
  }

  private hex4(): number {
    const digits = this.text.slice(this.at, this.at + 4);
    if (!/^[0-9a-fA-F]{4}$/.test(digits)) this.fail("bad \\u escape");
    this.at += 4;
    return parseInt(digits, 16);
  }

  private string(): string {
    this.at++; // the opening quote
    let out = "";
    let start = this.at;
    for (;;) {
      if (this.at >= this.text.length) this.fail("unterminated string");
      const code = this.text.charCodeAt(this.at);
      if (code === 0x22) break;
      if (code < 0x20) this.fail("control character in a string");
      if (code !== 0x5c) {
        this.at++;
        continue;
      }
      out += this.text.slice(start, this.at);
      this.at++;
      const escaped = this.text[this.at++];
      switch (escaped) {
        case '"':
        case "\\":
        case "/":
          out += escaped;
          break;
        case "b":
          out += "\b";
          break;
        case "f":
          out += "\f";
          break;
        case "n":
          out += "\n";
          break;
        case "r":
          out += "\r";
          break;
        case "t":
          out += "\t";
          break;
        case "u": {
          const unit = this.hex4();
          if (unit >= 0xdc00 && unit <= 0xdfff) throw new BadRequest("a string holds a lone surrogate");
          if (unit >= 0xd800 && unit <= 0xdbff) {
            if (!this.text.startsWith("\\u", this.at)) throw new BadRequest("a string holds a lone surrogate");
            this.at += 2;
            const low = this.hex4();
            if (low < 0xdc00 || low > 0xdfff) throw new BadRequest("a string holds a lone surrogate");
            out += String.fromCharCode(unit, low);
          } else {
            out += String.fromCharCode(unit);
          }
          break;
        }
        default:
          this.fail("bad escape");
      }
      start = this.at;
    }
    out += this.text.slice(start, this.at);
    this.at++; // the closing quote
    return out;
  }

  private number(): number | JsonFloat {
    NUMBER.lastIndex = this.at;
    const match = NUMBER.exec(this.text);
    if (match === null) this.fail("unexpected character");
    const written = match[0];
    this.at += written.length;
    if (match[1] !== undefined || match[2] !== undefined) return new JsonFloat(written);
    const value = Number(written);
    // An integer beyond a double is still an integer: out of every range, never a non-number.
    if (!Number.isFinite(value)) return written.startsWith("-") ? -Number.MAX_VALUE : Number.MAX_VALUE;
    return value === 0 ? 0 : value; // -0 is the integer 0
  }
}
