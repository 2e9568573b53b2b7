// Plot styles (no DOM): a colour per motor and a line style per signal, so that any mix of
// motors and signals stays distinct up to 24 motors (issue #37: ID 6's position had ID 1's
// colour after 15 series). Colours are mid-light, readable on the light and the dark page.

/** 24 colours, one per motor in the order of their IDs; hand-picked to differ in hue or lightness. */
export const MOTOR_COLOURS = [
  "#2f6fdf", // blue
  "#e07b00", // orange
  "#0f9d58", // green
  "#8e44d8", // violet
  "#e0337c", // pink
  "#0aa1bf", // cyan
  "#7aa300", // olive green
  "#d93a2b", // red
  "#7b8794", // grey
  "#c9a000", // mustard
  "#00a88f", // teal
  "#b0489c", // plum
  "#1b3f99", // navy
  "#a0522d", // brown
  "#5fbf3f", // light green
  "#f25c9a", // light pink
  "#45b8f5", // sky
  "#ff9f40", // light orange
  "#6b4fbb", // indigo
  "#ff6f61", // coral
  "#c2185b", // raspberry
  "#8d6e00", // dark gold
  "#5c7cfa", // periwinkle
  "#e65100", // burnt orange
];

/** One line style per signal (canvas dash patterns; none = solid). */
export const SIGNAL_DASH = {
  position: undefined,
  target: [10, 5],
  error: [2, 4],
  device: [12, 4, 2, 4],
  speed: [5, 4],
  current: [2, 3, 8, 3],
};

/** The stroke and dash of one motor's signal; `motorIndex`: the motor's place among all motors by ID. */
export function seriesStyle(motorIndex, signal) {
  return { stroke: MOTOR_COLOURS[motorIndex % MOTOR_COLOURS.length], dash: SIGNAL_DASH[signal] };
}

/** The time windows the Plot view offers, seconds (the series keep 60 s). */
export const WINDOWS_S = [5, 10, 30, 60];
