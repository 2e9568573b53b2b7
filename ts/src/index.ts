/**
 * nurimc: Nurirobot MC / BLMC-H controllers on RS485 (MC-RS485 V1.0.1).
 * Environment-neutral (Node and browsers); the Node serial port is in "nurimc/node".
 */

export * from "./backup.js";
export * from "./bus/client.js";
export * from "./bus/errors.js";
export * from "./bus/port.js";
export * from "./bus/reconnect.js";
export * from "./bus/timing.js";
export * from "./codec.js";
export * from "./discovery.js";
export * from "./errors.js";
export { buildFrame, checksum, fromHex, toHex } from "./frame.js";
export * from "./generated/host.js";
export * from "./generated/messages.js";
export * from "./generated/tables.js";
export * from "./lines.js";
export * from "./linesettings.js";
export * from "./motor.js";
export * from "./parser.js";
export { type WebSerialDevice, WebSerialPort } from "./ports/webserial.js";
export type * from "./schema.js";
export * from "./settings.js";
export * from "./stepfigures.js";
export * as units from "./units.js";
export { type SignedWire, UnitRangeError } from "./units.js";
