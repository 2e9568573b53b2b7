import { describe, expect, it } from "vitest";
import { Bus } from "../src/bus/client.js";
import { VerifyError } from "../src/bus/errors.js";
import { decode, encode, type Message, make, toRecord } from "../src/codec.js";
import { HOLD_RPM, Motor, TurnTracker, UnconfirmedReadError } from "../src/motor.js";
import { UnitRangeError } from "../src/units.js";
import { FakePort } from "./fake-port.js";

/** A minimal controller at ID 2 that stores its settings (unless `deaf`) and reports a position. */
function controller(options: { deaf?: boolean; relative?: boolean; released?: boolean } = {}) {
  const state = {
    rated_speed: 3000,
    ratio: 10,
    control: options.released === true ? 1 : 0,
    position_mode: options.relative === true ? 1 : 0,
    gains: { kp: 50, ki: 0, kd: 10, rated_current: 50 },
    direction: 1,
    position: 18001,
  };
  const sent: Message[] = [];
  const port = new FakePort((written) => {
    const m = decode(written);
    sent.push(m);
    if (m.id !== 2) return null;
    const stores = options.deaf !== true;
    switch (m.name) {
      case "set_rated_speed":
        if (stores) state.rated_speed = m.rated_speed;
        return null;
      case "set_ratio":
        if (stores) state.ratio = m.ratio;
        return null;
      case "set_control":
        state.control = m.control;
        return null;
      case "set_position_gains":
        if (stores) state.gains = { kp: m.kp, ki: m.ki, kd: m.kd, rated_current: m.rated_current };
        return null;
      case "request_rated_speed":
        return encode(make("rated_speed", 2, { rated_speed: state.rated_speed }));
      case "request_ratio":
        return encode(make("ratio", 2, { ratio: state.ratio }));
      case "request_control":
        return encode(make("control", 2, { control: state.control }));
      case "request_position_mode":
        return encode(make("position_mode", 2, { position_mode: state.position_mode }));
      case "request_position_gains":
        return encode(make("position_gains", 2, state.gains));
      case "request_position":
        return encode(
          make("position_feedback", 2, {
            direction: state.direction,
            position: state.position,
            speed: 1234,
            current: 15,
          }),
        );
      case "request_speed":
        return encode(make("speed_feedback", 2, { direction: 1, speed: 255, position: 1800, current: 3 }));
      default:
        return null;
    }
  });
  const bus = new Bus(port, { timing: { latencyMs: 10 }, busyWindowMs: 1 });
  const commands = () => sent.filter((m) => !m.name.startsWith("request_")).map(toRecord);
  return { port, bus, sent, state, commands, motor: new Motor(bus, 2) };
}

describe("Motor: motion in signed units, as the Python library", () => {
  it("sends signed degrees and RPM as direction and magnitude, rounded by the shared rule", async () => {
    const { motor, commands } = controller();
    await motor.moveTo(-180.005, { rpm: 100 });
    await motor.moveTo(90, { seconds: 1.5 });
    await motor.run(-2.55, 2);
    await motor.run(30);
    await motor.release();
    expect(commands()).toEqual([
      { id: 2, message: "position_speed", direction: 1, position: 18001, speed: 1000 },
      { id: 2, message: "accel_position", direction: 0, position: 9000, arrival_time: 15 },
      { id: 2, message: "accel_speed", direction: 1, speed: 26, arrival_time: 20 },
      { id: 2, message: "accel_speed", direction: 0, speed: 300, arrival_time: 1 },
      { id: 2, message: "set_control", control: 1 },
    ]);
  });

  it("refuses values outside the limits before sending anything", async () => {
    const { motor, sent } = controller();
    await expect(motor.moveTo(655.335, { rpm: 100 })).rejects.toThrow(UnitRangeError);
    await expect(motor.moveTo(-700, { rpm: 100 })).rejects.toThrow(
      /degrees = -700 is out of range; allowed: -655\.33\.\.655\.33 deg/,
    );
    await expect(motor.run(0)).rejects.toThrow(/rpm = 0 is out of range/);
    await expect(motor.run(10, 30)).rejects.toThrow(/seconds = 30 is out of range; allowed: 0\.1\.\.25\.5 s/);
    await expect(motor.moveTo(10, {} as { rpm: number })).rejects.toThrow(/exactly one of/);
    expect(sent).toEqual([]);
    expect(motor.makeMoveTo(655.334, { rpm: 1 })).toMatchObject({ position: 65533 }); // rounded, then checked
  });

  it("moves by a signed amount from where the motor is (absolute mode)", async () => {
    const { motor, commands } = controller(); // at -180.01
    await motor.moveBy(10, { rpm: 50 });
    expect(commands()).toEqual([{ id: 2, message: "position_speed", direction: 1, position: 17001, speed: 500 }]);
  });

  it("in relative mode, moveTo sends the step from here and moveBy the amount", async () => {
    const { motor, commands } = controller({ relative: true }); // at -180.01
    await motor.moveTo(-170.01, { rpm: 50 });
    await motor.moveBy(-5, { rpm: 50 });
    expect(commands()).toEqual([
      { id: 2, message: "position_speed", direction: 0, position: 1000, speed: 500 },
      { id: 2, message: "position_speed", direction: 1, position: 500, speed: 500 },
    ]);
  });

  it("switches control on before moving a released motor", async () => {
    const { motor, commands } = controller({ released: true });
    await motor.run(-12.5);
    expect(commands()).toEqual([
      { id: 2, message: "set_control", control: 0 },
      { id: 2, message: "accel_speed", direction: 1, speed: 125, arrival_time: 1 },
    ]);
  });

  it("hold switches control on and re-targets the present position (absolute mode)", async () => {
    const { motor, commands } = controller({ released: true });
    await motor.hold();
    expect(commands()).toEqual([
      { id: 2, message: "set_control", control: 0 },
      { id: 2, message: "position_speed", direction: 1, position: 18001, speed: HOLD_RPM * 10 },
    ]);
  });

  it("hold in relative mode only switches control on (a relative target would move)", async () => {
    const { motor, commands } = controller({ relative: true });
    await motor.hold();
    expect(commands()).toEqual([{ id: 2, message: "set_control", control: 0 }]);
  });
});

describe("Motor: feedback", () => {
  it("reads the state in signed degrees, RPM and amperes", async () => {
    const { motor } = controller();
    expect(await motor.readState()).toEqual({
      id: 2,
      position: -180.01,
      devicePosition: -180.01,
      speed: 123.4,
      current: 1.5,
      direction: "cw",
    });
    expect(await motor.readSpeed()).toBe(-25.5);
  });

  it("tracks turns across the counter's wrap", async () => {
    const { motor, state } = controller();
    state.direction = 0;
    state.position = 65000; // 650 deg CCW
    expect((await motor.readState()).position).toBe(650);
    state.position = 500; // wrapped: 5 deg on the device
    expect(await motor.readState()).toMatchObject({ devicePosition: 5, position: 660.36 });
    const tracker = new TurnTracker();
    expect([10, -300, 300, -10].map((d) => tracker.update(d))).toEqual([10, -300, -355.36, -665.36]);
  });
});

describe("Motor: settings by name, in physical units", () => {
  it("writes a setting, verifies it by reading back and returns what was stored", async () => {
    const { motor, state } = controller();
    expect(await motor.set("rated-speed", 2000)).toBe(2000);
    expect(state.rated_speed).toBe(2000);
    expect(await motor.set("ratio", 12.34)).toBe(12.3);
    expect(await motor.get("ratio")).toBe(12.3);
    expect(await motor.set("control", "off")).toBe("off");
    expect(await motor.get("control")).toBe("off");
  });

  it("writes one gain and keeps the others (read-modify-write)", async () => {
    const { motor, state } = controller();
    await motor.set("position_kp", 60);
    await motor.set("position-rated-current", 4.5);
    expect(state.gains).toEqual({ kp: 60, ki: 0, kd: 10, rated_current: 45 });
  });

  it("builds a gains write only from two reads that agree: a same-sum corrupted answer is never written back", async () => {
    const { motor, state, port } = controller();
    const answer = port.responder;
    let reads = 0;
    port.responder = (written, p) => {
      const reply = answer(written, p);
      if (decode(written).name === "request_position_gains" && reads++ === 0 && reply instanceof Uint8Array) {
        const noisy = reply.slice(); // ki +100, kd -100: the checksum still holds
        noisy[7] = ((noisy[7] ?? 0) + 100) & 0xff;
        noisy[8] = ((noisy[8] ?? 0) - 100) & 0xff;
        return noisy;
      }
      return reply;
    };
    await motor.set("position-kp", 60);
    expect(state.gains).toEqual({ kp: 60, ki: 0, kd: 10, rated_current: 50 });
  });

  it("writes nothing when no two reads agree", async () => {
    const { motor, port, commands } = controller();
    const answer = port.responder;
    let reads = 0;
    port.responder = (written, p) => {
      const reply = answer(written, p);
      if (decode(written).name !== "request_position_gains" || !(reply instanceof Uint8Array)) return reply;
      const noisy = reply.slice();
      reads += 1;
      noisy[7] = ((noisy[7] ?? 0) + reads) & 0xff;
      noisy[8] = ((noisy[8] ?? 0) - reads) & 0xff;
      return noisy;
    };
    await expect(motor.set("position-kp", 60)).rejects.toBeInstanceOf(UnconfirmedReadError);
    expect(commands()).toEqual([]);
  });

  it("refuses values the setting cannot take, before sending anything", async () => {
    const { motor, sent } = controller();
    await expect(motor.set("control", "sideways")).rejects.toThrow(/allowed: on or off/);
    await expect(motor.set("position-kp", 2.5)).rejects.toThrow(
      /position-kp = 2\.5 is out of range; allowed: 1\.\.254/,
    );
    await expect(motor.set("ratio", 0.04)).rejects.toThrow(UnitRangeError);
    await expect(motor.set("firmware", 3)).rejects.toThrow(/read-only/);
    await expect(motor.set("speed", 3)).rejects.toThrow(/unknown setting "speed"; settings: position-kp/);
    expect(sent).toEqual([]);
  });

  it("raises VerifyError when the controller did not take the setting", async () => {
    const { motor } = controller({ deaf: true });
    const failure = motor.set("rated-speed", 2000);
    await expect(failure).rejects.toBeInstanceOf(VerifyError);
    await expect(failure).rejects.toThrow(/rated-speed: wrote 2000 but the controller reports 3000/);
  });

  it("says false to a ping nobody answers", async () => {
    const motor = new Motor(new Bus(controller().port, { retries: 0 }), 9);
    expect(await motor.ping()).toBe(false);
  });
});

describe("motion and the emergency stop", () => {
  it("sends nothing of a move begun before the stop, and reads control again after it", async () => {
    const { bus, sent, state, motor } = controller();
    const move = motor.moveTo(90, { rpm: 60 }); // needs the position mode and control read first
    await bus.emergency(make("set_control", 255, { control: 1 }));
    await expect(move).rejects.toThrow(/emergency stop/);
    const stopAt = sent.findIndex((m) => m.name === "set_control" && m.id === 255);
    expect(sent.slice(stopAt).filter((m) => m.name === "position_speed")).toEqual([]);
    state.control = 1; // the broadcast turned it off
    await motor.moveTo(45, { rpm: 60 }); // a new command after the stop
    const after = sent.slice(stopAt + 1).map((m) => m.name);
    expect(after).toContain("request_control"); // what it knew about control was forgotten
    expect(after.filter((n) => n === "set_control")).toHaveLength(1); // control on again, then the move
    expect(after.at(-1)).toBe("position_speed");
  });
});
