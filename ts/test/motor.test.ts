import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { VerifyError } from "../src/bus/errors.js";
import { decode, encode, type Message, make, toRecord } from "../src/codec.js";
import { FieldRangeError } from "../src/errors.js";
import { Motor } from "../src/motor.js";
import { FakePort } from "./fake-port.js";

/** A minimal controller at ID 2: stores rated speed and control (unless `deaf`), answers their requests. */
function controller(options: { deaf?: boolean } = {}) {
  const state = { rated_speed: 3000, control: 0 };
  const sent: Message[] = [];
  const port = new FakePort((written) => {
    const m = decode(written);
    sent.push(m);
    if (m.id !== 2 && m.id !== 255) return null;
    if (m.name === "set_rated_speed" && options.deaf !== true) state.rated_speed = m.rated_speed;
    if (m.name === "set_control") state.control = m.control;
    if (m.name === "request_rated_speed") return encode(make("rated_speed", 2, { rated_speed: state.rated_speed }));
    if (m.name === "request_control") return encode(make("control", 2, { control: state.control }));
    if (m.name === "request_position")
      return encode(make("position_feedback", 2, { direction: 1, position: 18001, speed: 1234, current: 15 }));
    return null;
  });
  return { port, sent, state };
}

describe("Motor", () => {
  it("sends motion in physical units, rounded by the shared rule", async () => {
    const { port, sent } = controller();
    const motor = new Motor(new Bus(port, { timing: { latencyMs: 10 } }), 2);
    await motor.moveTo(180.005, 100, "cw");
    await motor.moveIn(90, 1.5);
    await motor.run(2.55, "ccw", 2);
    await motor.release();
    expect(sent.map(toRecord)).toEqual([
      { id: 2, message: "position_speed", direction: 1, position: 18001, speed: 1000 },
      { id: 2, message: "accel_position", direction: 0, position: 9000, arrival_time: 15 },
      { id: 2, message: "accel_speed", direction: 0, speed: 26, arrival_time: 20 },
      { id: 2, message: "set_control", control: 1 },
    ]);
  });

  it("refuses values outside the wire range before sending anything", async () => {
    const { port, sent } = controller();
    const motor = new Motor(new Bus(port), 2);
    await expect(motor.moveTo(700, 100)).rejects.toThrow(FieldRangeError);
    await expect(motor.moveTo(700, 100)).rejects.toThrow(
      /position = 70000 is out of range; allowed: 0\.\.65533 \(0\.\.655\.33 deg\)/,
    );
    await expect(motor.run(0, "cw")).rejects.toThrow(/speed = 0 is out of range/);
    expect(sent).toEqual([]);
  });

  it("reads the state in physical units", async () => {
    const motor = new Motor(new Bus(controller().port, { timing: { latencyMs: 10 } }), 2);
    expect(await motor.readState()).toEqual({ position: 180.01, direction: "cw", speed: 123.4, current: 1.5 });
  });

  it("writes a setting and verifies it by reading it back", async () => {
    const { port, state } = controller();
    const motor = new Motor(new Bus(port, { timing: { latencyMs: 10 } }), 2, { settleMs: 1 });
    await motor.writeSetting("rated_speed", 2000);
    expect(state.rated_speed).toBe(2000);
    await motor.writeSetting("control", "off");
    expect(await motor.readSetting("control")).toBe("off");
    await expect(motor.writeSetting("control", "sideways")).rejects.toThrow(/use one of on, off/);
  });

  it("raises VerifyError when the controller did not take the setting", async () => {
    const motor = new Motor(new Bus(controller({ deaf: true }).port, { timing: { latencyMs: 10 } }), 2, {
      settleMs: 1,
    });
    const failure = motor.writeSetting("rated_speed", 2000);
    await expect(failure).rejects.toBeInstanceOf(VerifyError);
    await expect(failure).rejects.toThrow(/rated_speed: wrote 2000 but the controller reports 3000/);
  });

  it("says false to a ping nobody answers", async () => {
    const motor = new Motor(new Bus(controller().port, { retries: 0 }), 9);
    expect(await motor.ping()).toBe(false);
  });
});
