// A motor's state at a glance (pure): what its badge says.
export const NOT_ANSWERING_S = 1; // no sample for this long while watched: not answering
export const MOVING_RPM = 0.5; // speed above this: moving

/**
 * motor: { stopped, busy, control: "on"|"off"|null, lastSampleAt, lastErrorAt, speed, portDown }, now (s, page clock).
 * Precedence: the server's port lost (nothing can answer, whatever was known before); an emergency stop is shown until a new command; then a settings write in progress;
 * then silence; then control off; then motion.
 */
export function motorState(motor, now) {
  if (motor.portDown) return "silent";
  if (motor.stopped) return "stopped";
  if (motor.busy > 0) return "busy";
  const silent = motor.lastSampleAt == null ? motor.lastErrorAt != null : now - motor.lastSampleAt > NOT_ANSWERING_S;
  if (silent || (motor.lastErrorAt != null && motor.lastErrorAt > (motor.lastSampleAt ?? -Infinity))) return "silent";
  if (motor.control === "off") return "off";
  if (motor.speed != null && Math.abs(motor.speed) > MOVING_RPM) return "moving";
  if (motor.control === "on") return "on";
  return "unknown";
}
