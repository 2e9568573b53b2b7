/** Errors of the bus client. Each says what happened and what to check. */
import type { Message } from "../codec.js";

export class BusError extends Error {
  override name = "BusError";
}

/** The port itself failed (missing device, no permission, unplugged). */
export class PortError extends BusError {
  override name = "PortError";
  constructor(text: string, options?: { cause?: unknown }) {
    super(text, options);
  }
}

/** An emergency stop emptied the queue: this call was not sent (or its answer is no longer awaited). */
export class CancelledError extends BusError {
  override name = "CancelledError";
}

/** The bus was closed; nothing more can be sent. */
export class BusClosedError extends BusError {
  override name = "BusClosedError";
}

const describe = (request: Message): string => `${request.name} to ID ${request.id}`;

/** Silence: not one byte of an answer arrived within the timeout, on every attempt. */
export class NoAnswerError extends BusError {
  override name = "NoAnswerError";
  readonly likelyCauses: readonly string[];
  constructor(
    readonly request: Message,
    readonly attempts: number,
    readonly timeoutMs: number,
    readonly baudRate: number,
  ) {
    const causes = [
      `no controller has ID ${request.id} (scan the bus)`,
      `the controller is not at ${baudRate} bps (it understands only its own rate)`,
      "wiring: A/B swapped, no common ground, adapter not in RS485 mode",
      "a long bus without 120 ohm termination at both ends",
      "the controller is busy writing a setting to EEPROM (50-300 ms after a settings command)",
    ];
    super(
      `no answer to ${describe(request)} after ${attempts} attempt(s) of ${timeoutMs.toFixed(1)} ms at ${baudRate} bps; likely causes: ${causes.join("; ")}`,
    );
    this.likelyCauses = causes;
  }
}

/** Bytes came back, but no valid answer among them. */
export class CorruptedAnswerError extends BusError {
  override name = "CorruptedAnswerError";
  constructor(
    readonly request: Message,
    readonly attempts: number,
    readonly droppedBytes: number,
    readonly badChecksums: number,
  ) {
    super(
      `corrupted answer to ${describe(request)} after ${attempts} attempt(s): ${droppedBytes} unusable byte(s), ` +
        `${badChecksums} bad checksum(s); likely causes: electrical noise or missing termination, ` +
        "two controllers with the same ID answering at once, or a controller at another baud rate",
    );
  }
}

/** Valid frames came back, but none is the answer this request calls for. */
export class UnexpectedAnswerError extends BusError {
  override name = "UnexpectedAnswerError";
  constructor(
    readonly request: Message,
    readonly received: readonly Message[],
  ) {
    const got = received.map((m) => `${m.name} from ID ${m.id}`).join(", ");
    super(
      `unexpected answer to ${describe(request)}: got ${got}; another host on the bus, ` +
        "or a controller answering late, may be talking at the same time",
    );
  }
}

/** A setting written and read back differs: the controller did not take it. */
export class VerifyError extends BusError {
  override name = "VerifyError";
  constructor(
    readonly setting: string,
    readonly written: unknown,
    readonly readBack: unknown,
  ) {
    super(
      `${setting}: wrote ${JSON.stringify(written)} but the controller reports ${JSON.stringify(readBack)}; ` +
        "the write was lost (noise, busy controller) or the value is beyond what this product accepts",
    );
  }
}

/**
 * No answer while the controller may still be writing its settings to EEPROM: the request
 * was sent less than one more busy window after the ID's window ended (docs/protocol.md,
 * Busy window, rule 6). A NoAnswerError, so code that catches silence still catches it.
 */
export class ControllerBusyError extends NoAnswerError {
  override name = "ControllerBusyError";
  constructor(
    request: Message,
    attempts: number,
    timeoutMs: number,
    baudRate: number,
    readonly busyWindowMs: number,
  ) {
    super(request, attempts, timeoutMs, baudRate);
    this.message =
      `no answer to ${describe(request)} after ${attempts} attempt(s): controller ${request.id} is busy writing its ` +
      `settings (EEPROM) right after a settings command; give it a longer busy window than ${busyWindowMs} ms ` +
      "(BusOptions.busyWindowMs or busyWindowsMs)";
  }
}
