/** nurimc for Node: everything in "nurimc" plus the serial port of the npm `serialport` package. */
export * from "./index.js";
export { NodeSerialPort } from "./ports/node.js";
