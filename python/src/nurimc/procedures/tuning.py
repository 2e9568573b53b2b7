"""Automatic tuning (docs/tuning.md): a model-free search of a loop's integer gains on the motor.

The controller is a black box (the document gives only the gains' ranges; their scaling
differs per product), so the tuner measures, changes, measures again: each trial writes one
gain set (one EEPROM write, the busy window waited out by the bus core), makes one small step
inside the envelope and judges the response with nurimc.procedures.stepresponse.

Method: a pattern (coordinate) search in the gains' log space from the starting gains. Each
sweep tries every gain a factor (1 + r) up and down, keeps the first set that scores better,
and halves r after a sweep without improvement; the best-so-far is always kept, a gain set is
tried at most once, and one that was aborted is never tried again.

Safety: the envelope (travel around the start position, speed, current) is given up front; a
reading outside it, an oscillation or too much current ends the trial at once with control
off. The starting gains are read first (two agreeing reads) and written back on cancel,
Ctrl+C, any error, a lost port or an E-STOP from another program (control found off); the
caller's restore journal covers a port that is lost for good.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from typing import Any

from ..core.actions import Note, Now, Procedure, Wait
from ..errors import InputError, NoAnswer, NurimcError, PortLost
from ..protocol import Message
from .settings import confirmed_answer, setting
from .stepresponse import ResponseFigures, response_figures

# The motor is a nurimc.procedures.motor.MotorProcedures, and a reading its MotorState; they are not
# imported here (not even for types): motor.py's tune() imports this module, and the package
# has no import cycles (tests/test_imports.py).
MotorProcedures = Any
MotorState = Any

LOOPS = ("position", "speed")
#: goal presets: (max overshoot %, objective); the objective weighs settling, overshoot and current
GOALS: dict[str, dict[str, float]] = {
    "stiff": {"max_overshoot": 10.0, "settling": 1.0, "overshoot": 0.002, "current": 0.0},
    "smooth": {"max_overshoot": 2.0, "settling": 1.0, "overshoot": 0.02, "current": 0.05},
    "no-overshoot": {"max_overshoot": 1.0, "settling": 1.0, "overshoot": 1.0, "current": 0.0},
}
DEFAULT_TRAVEL = 30.0  # deg around the start position
DEFAULT_MAX_RPM = 30.0
DEFAULT_MAX_CURRENT = 3.0  # A
DEFAULT_TRIALS = 24
MIN_STEP = 2.0  # deg: a smaller position step cannot be told from the reading's resolution
MIN_STEPS_PER_STEP = 10  # reading steps a position step must span to be measured
MIN_WINDOW = 0.15  # s: a speed step shorter than this measures nothing
READ_AGAIN_AFTER = 0.1  # s before a failed reading is asked once more
SAMPLE_PAUSE = 0.005  # s between two readings in a trial (the wire sets the real rate)
SETTLE_PATIENCE = 1.5  # s a trial waits for the motor to come to rest after its window
SPEED_MARGIN = 1.3  # a reading above this times --max-rpm leaves the envelope
OSCILLATION_CROSSINGS = 4  # crossings of the target (outside the band) that call a response oscillating
START_RATIO = 0.5  # the search's first factor r: gains tried at (1 + r) and 1 / (1 + r)
LAST_RATIO = 0.08
GAIN_FIELDS = ("kp", "ki", "kd")
NONE_MEASURED = (
    "every trial was aborted: no gains were measured inside the envelope (widen it, or start from gentler gains)"
)
GAIN_RANGES = {"kp": (1, 254), "ki": (0, 254), "kd": (0, 254)}

Gains = tuple[int, int, int]


class TuneRefused(InputError):
    """The tune cannot start (an envelope too small to measure, a bad goal): nothing moved."""


class TuneStopped(NurimcError):
    """The tune stopped before its end (E-STOP from another program, no answer, a lost port, a
    cancel); `restored` says what was written back, `result` holds the trials so far."""

    def __init__(self, message: str, result: TuneResult | None = None, restored: bool = False) -> None:
        super().__init__(message)
        self.result = result
        self.restored = restored


@dataclass(frozen=True, slots=True)
class Envelope:
    travel: float = DEFAULT_TRAVEL  # deg either side of the start position
    max_rpm: float = DEFAULT_MAX_RPM
    max_current: float = DEFAULT_MAX_CURRENT  # A


@dataclass(frozen=True, slots=True)
class Goal:
    name: str  # a preset, or "limits"
    max_overshoot: float  # %
    max_settling: float | None  # s, None: as short as it gets
    weights: dict[str, float]


def make_goal(goal: str | None, max_overshoot: float | None = None, max_settling: float | None = None) -> Goal:
    """A preset (default no-overshoot) with the explicit limits over it."""
    name = goal or ("limits" if max_overshoot is not None or max_settling is not None else "no-overshoot")
    preset = GOALS.get(name if name != "limits" else "stiff")
    if preset is None:
        raise TuneRefused(f"goal {goal!r}: use one of {', '.join(GOALS)} (or --max-overshoot / --max-settling)")
    if max_overshoot is not None and not (math.isfinite(max_overshoot) and 0 <= max_overshoot <= 100):
        raise TuneRefused(f"max overshoot {max_overshoot:g} %: give a percentage, 0..100")
    if max_settling is not None and not (math.isfinite(max_settling) and 0 < max_settling <= 30):
        raise TuneRefused(f"max settling {max_settling:g} s: give seconds, more than 0 and at most 30")
    return Goal(
        name,
        preset["max_overshoot"] if max_overshoot is None else max_overshoot,
        max_settling,
        {k: v for k, v in preset.items() if k != "max_overshoot"},
    )


@dataclass(frozen=True, slots=True)
class Trial:
    number: int
    gains: Gains
    figures: ResponseFigures | None  # None when it was aborted before a response was measured
    score: float  # lower is better; inf for an aborted trial
    aborted: str | None = None  # why the trial was stopped (control off), or None
    samples: tuple[tuple[float, float], ...] = ()  # (time from the step, value) as read
    start: float = 0.0  # where the step began (deg; 0 RPM for a speed step)
    target: float = 0.0  # the step's target (deg, or RPM)

    def as_dict(self) -> dict[str, Any]:
        return {
            "trial": self.number,
            "gains": dict(zip(GAIN_FIELDS, self.gains, strict=True)),
            "figures": None if self.figures is None else self.figures.as_dict(),
            "score": None if math.isinf(self.score) else round(self.score, 4),
            "aborted": self.aborted,
            "start": self.start,
            "target": self.target,
        }


@dataclass(slots=True)
class TuneResult:
    loop: str
    goal: Goal
    envelope: Envelope
    start_gains: Gains
    rated_current: int  # the loop's rated current setting (raw, 100 mA), kept as it was
    trials: list[Trial] = field(default_factory=list)
    best: Trial | None = None
    applied: bool = False  # the chosen gains were left on the controller
    unmet: list[str] = field(default_factory=list)  # limits the best trial does not meet

    @property
    def start(self) -> Trial | None:
        return self.trials[0] if self.trials else None

    def as_dict(self) -> dict[str, Any]:
        def gains(g: Gains) -> dict[str, int]:
            return dict(zip(GAIN_FIELDS, g, strict=True))

        return {
            "loop": self.loop,
            "goal": {
                "name": self.goal.name,
                "max_overshoot": self.goal.max_overshoot,
                "max_settling": self.goal.max_settling,
            },
            "envelope": {
                "travel": self.envelope.travel,
                "max_rpm": self.envelope.max_rpm,
                "max_current": self.envelope.max_current,
            },
            "start_gains": gains(self.start_gains),
            "chosen_gains": None if self.best is None else gains(self.best.gains),
            "start": None if self.start is None else self.start.as_dict(),
            "chosen": None if self.best is None else self.best.as_dict(),
            "unmet": self.unmet,
            "applied": self.applied,
            "trials": [t.as_dict() for t in self.trials],
        }


@dataclass(frozen=True, slots=True)
class TrialStarted:
    """A Note: trial `number` of `budget` begins with these gains."""

    number: int
    budget: int
    gains: Gains


@dataclass(frozen=True, slots=True)
class TrialSample:
    """A Note: one reading of the running trial (time from the step, value)."""

    number: int
    t: float
    value: float
    state: MotorState | None = None  # the whole reading (the console's live plots)


@dataclass(frozen=True, slots=True)
class TrialDone:
    """A Note: a trial's figures (its row in a table of trials), and the best so far."""

    trial: Trial
    best: Trial | None


def check_envelope(loop: str, envelope: Envelope, trials: int) -> None:
    """Refuse, before anything moves, an envelope too small to measure anything."""
    if loop not in LOOPS:
        raise TuneRefused(f"loop {loop!r}: use position or speed")
    if not (math.isfinite(envelope.travel) and envelope.travel > 0):
        raise TuneRefused(f"travel {envelope.travel:g}°: give degrees around the present position, more than 0")
    if not (math.isfinite(envelope.max_rpm) and envelope.max_rpm >= 1):
        raise TuneRefused(f"max rpm {envelope.max_rpm:g}: give at least 1 RPM")
    if not (math.isfinite(envelope.max_current) and 0.1 <= envelope.max_current <= 25.4):
        raise TuneRefused(f"max current {envelope.max_current:g} A: give 0.1..25.4 A")
    if not 2 <= trials <= 500:
        raise TuneRefused(f"trials {trials}: give 2..500 (the first trial measures the starting gains)")
    if loop == "position" and envelope.travel / 2 < MIN_STEP:
        raise TuneRefused(
            f"travel {envelope.travel:g}° is too small to measure a step (at least {2 * MIN_STEP:g}°); "
            "give a larger --travel"
        )
    if loop == "speed" and speed_window(envelope, envelope.travel) < MIN_WINDOW:
        raise TuneRefused(
            f"travel {envelope.travel:g}° at {envelope.max_rpm:g} RPM is too short to measure a speed step "
            f"(at least {MIN_WINDOW:g} s of running); give a larger --travel or a smaller --max-rpm"
        )


def speed_window(envelope: Envelope, room: float) -> float:
    """Seconds a speed step may run at 0.8 x max rpm within `room` degrees (half kept for the stop)."""
    return 0.5 * room / (0.8 * envelope.max_rpm * 6.0)


def score(figures: ResponseFigures, goal: Goal, window: float) -> tuple[float, list[str]]:
    """Lower is better; a limit not met costs more than anything a met one can gain."""
    unmet: list[str] = []
    settling = figures.settling_time if figures.settling_time is not None else 2 * window
    excess = 0.0  # how far past the limits, overshoot in % and settling in 1/20 s
    if figures.overshoot > goal.max_overshoot:
        unmet.append(f"overshoot {figures.overshoot:g} % > {goal.max_overshoot:g} %")
        excess += figures.overshoot - goal.max_overshoot
    if figures.settling_time is None:
        unmet.append("did not settle")
        excess += 20.0 * window
    elif goal.max_settling is not None and figures.settling_time > goal.max_settling:
        unmet.append(f"settling {figures.settling_time:g} s > {goal.max_settling:g} s")
        excess += 20.0 * (figures.settling_time - goal.max_settling)
    penalty = 10.0 + excess if unmet else 0.0
    w = goal.weights
    cost = w["settling"] * settling + w["overshoot"] * figures.overshoot + w["current"] * figures.current_peak
    return penalty * 100.0 + cost + 0.001 * abs(figures.final_error), unmet


def neighbours(gains: Gains, ratio: float) -> Iterator[Gains]:
    """Each gain (1 + ratio) up and down, in the integer range (at least one step of change)."""
    for i, name in enumerate(GAIN_FIELDS):
        low, high = GAIN_RANGES[name]
        value = gains[i]
        up = max(value + 1, round(value * (1 + ratio))) if value else max(1, round(8 * ratio))
        down = min(value - 1, round(value / (1 + ratio)))
        for candidate in (up, down):
            if low <= candidate <= high and candidate != value:
                yield (*gains[:i], candidate, *gains[i + 1 :])  # type: ignore[misc]


class Tuner:
    """One tune of one loop of one motor: a procedure (`run`) plus what it learned."""

    def __init__(
        self,
        motor: MotorProcedures,
        loop: str = "position",
        goal: Goal | None = None,
        envelope: Envelope | None = None,
        trials: int = DEFAULT_TRIALS,
        window: float | None = None,
    ) -> None:
        self.motor = motor
        self.loop = loop
        self.goal = goal or make_goal(None)
        self.envelope = envelope or Envelope()
        self.budget = trials
        check_envelope(loop, self.envelope, trials)
        self.window = window if window is not None else max(1.2, 2.0 * (self.goal.max_settling or 0.0))
        if not 0.1 <= self.window <= 30:
            raise TuneRefused(f"trial window {self.window:g} s: give 0.1..30 s")
        self.result: TuneResult | None = None
        self.restored: bool | None = None  # after an interruption: were the starting gains written back
        self._on_controller: Gains | None = None  # what the controller holds now (as written)
        self._released_by_us = False
        self._home = 0.0

    # --- the gains on the wire ---------------------------------------------------------
    def _names(self) -> tuple[str, str]:
        return f"request_{self.loop}_gains", f"set_{self.loop}_gains"

    def read_gains(self) -> Procedure[tuple[Gains, int]]:
        """The loop's gains and rated current, from two agreeing reads."""
        request, _ = self._names()
        answer: Message = yield from confirmed_answer(self.motor.core, self.motor._request(request, "the gains"))
        f = answer.fields()
        return (f["kp"], f["ki"], f["kd"]), f["rated_current"]

    def write_gains(self, gains: Gains, rated_current: int) -> Procedure[None]:
        """One EEPROM write of the three gains (the rated current as it was), read back."""
        _, command_name = self._names()
        fields = dict(zip(GAIN_FIELDS, gains, strict=True), rated_current=rated_current)
        command = self.motor._command(command_name, "the gains", **fields)
        self._on_controller = None  # unknown until the read-back confirms it
        yield from self.motor.write_verified(setting(f"{self.loop}-kp"), command, gains[0])
        self._on_controller = gains

    # --- the procedure ---------------------------------------------------------------------
    def run(self, apply: bool = False) -> Procedure[TuneResult]:
        """Tune; with `apply` leave the chosen gains on the controller, else write the starting
        gains back (the caller applies after asking: `apply_best`). Starting gains are written
        back on every error or interruption (then TuneStopped, or the interruption, propagates)."""
        if self.loop == "position":
            yield from self._check_resolution()  # before anything is written or moved
        start_gains, rated = yield from self.read_gains()
        result = self.result = TuneResult(self.loop, self.goal, self.envelope, start_gains, rated)
        self._on_controller = start_gains
        try:
            state = yield from self._read_state()
            self._home = state.device_position
            yield from self._check_not_stopped_elsewhere()
            yield from self._search(result)
            if result.best is not None and result.best.figures is None:
                result.best = None  # nothing was measured inside the envelope: nothing to choose
                result.unmet = [NONE_MEASURED]
            elif result.best is not None and result.best.figures is not None:
                result.unmet = score(result.best.figures, self.goal, self.window)[1]
            if apply and result.best is not None:
                yield from self._leave(result.best.gains, result)
                result.applied = True
            else:
                yield from self._leave(start_gains, result)
            return result
        except GeneratorExit:
            raise  # closed without being driven: nothing can be sent any more
        except BaseException as error:
            restored = yield from self._restore_after(error)
            if isinstance(error, NurimcError):
                said = (
                    f"restored the starting gains {_gains_text(start_gains)} (read back)"
                    if restored
                    else f"could NOT restore the starting gains {_gains_text(start_gains)}"
                )
                what = str(error) if isinstance(error, TuneStopped) else f"tune stopped: {error}"
                raise TuneStopped(f"{what}; {said}", result, restored) from error
            raise

    def _check_resolution(self) -> Procedure[None]:
        """Refuse a position step the reading cannot resolve: on a line with a resolution setting
        (MC: encoder pulses, 4 counts each, quadrature; BLMC-H: hall poles, 3 steps each), the
        reading moves in 360 / (counts x ratio) degree steps; a step needs MIN_STEPS_PER_STEP."""
        counts_per_unit = {"mc": 4, "blmc-h": 3}.get(self.motor.profile.key)
        if counts_per_unit is None or not self.motor.line.has("request_resolution"):
            return
        resolution = float((yield from self.motor.get("resolution")))
        ratio = float((yield from self.motor.get("ratio"))) if self.motor.line.has("request_ratio") else 1.0
        quantum = 360.0 / max(resolution * counts_per_unit * max(ratio, 0.1), 1e-9)
        step = self.envelope.travel / 2
        if step < MIN_STEPS_PER_STEP * quantum:
            unit = self.motor.profile.resolution_unit
            raise TuneRefused(
                f"ID {self.motor.id} reads its position in {quantum:.3g}° steps (resolution {resolution:g} {unit}, "
                f"ratio {ratio:g}): a {step:g}° step cannot be measured (at least {MIN_STEPS_PER_STEP} steps, "
                f"{MIN_STEPS_PER_STEP * quantum:.3g}°); give a larger --travel, or set the encoder's real resolution "
                "(nurimc set resolution N)"
            )

    def apply_best(self) -> Procedure[Gains]:
        """After a run without `apply`: write the chosen gains (read back)."""
        if self.result is None or self.result.best is None:
            raise InputError("nothing to apply: run the tune first")
        yield from self.write_gains(self.result.best.gains, self.result.rated_current)
        self.result.applied = True
        return self.result.best.gains

    def _restore_after(self, error: BaseException) -> Procedure[bool]:
        """Control off if a trial may be moving, then the starting gains back (read back)."""
        result = self.result
        assert result is not None
        self.restored = False
        if isinstance(error, PortLost):
            return False  # nothing reaches the controller: the caller's journal remembers
        try:
            yield from self.motor.release()
            self._released_by_us = True
            yield from self.write_gains(result.start_gains, result.rated_current)
        except NurimcError:
            return False
        self.restored = True
        return True

    def _leave(self, gains: Gains, result: TuneResult) -> Procedure[None]:
        """End: the motor at rest, holding, with `gains` on the controller."""
        if self._on_controller != gains:
            yield from self.write_gains(gains, result.rated_current)
        if self._released_by_us:
            yield from self.motor.hold()
            self._released_by_us = False

    def _check_not_stopped_elsewhere(self) -> Procedure[None]:
        control = yield from self.motor.get("control")
        if control == "off" and not self._released_by_us:
            raise TuneStopped(
                f"ID {self.motor.id}: control is off and the tuner did not turn it off (an E-STOP from another "
                "program?); nothing more was moved"
            )

    def _search(self, result: TuneResult) -> Procedure[None]:
        tried: dict[Gains, float] = {}
        best = yield from self._trial(result, result.start_gains, tried)
        unlimited = self.goal.name == "no-overshoot" and self.goal.max_settling is None
        if unlimited and best.figures is not None and best.figures.settling_time is not None:
            # no overshoot, and settling no longer than the starting gains' (when they settle)
            self.goal = replace(self.goal, max_settling=best.figures.settling_time)
            result.goal = self.goal
            best = replace(best, score=score(best.figures, self.goal, self.window)[0])
            result.trials[0] = result.best = best
        ratio = START_RATIO
        while len(result.trials) < self.budget and ratio >= LAST_RATIO:
            improved = False
            for candidate in neighbours(best.gains, ratio):
                if candidate in tried:
                    continue
                if len(result.trials) >= self.budget:
                    return
                trial = yield from self._trial(result, candidate, tried)
                if trial.score < best.score:
                    best = trial
                    improved = True
                    break  # opportunistic: move there and look around it
            if not improved:
                ratio /= 2

    def _trial(self, result: TuneResult, gains: Gains, tried: dict[Gains, float]) -> Procedure[Trial]:
        number = len(result.trials) + 1
        yield Note(TrialStarted(number, self.budget, gains))
        yield from self._check_not_stopped_elsewhere()
        if self._released_by_us:  # the last trial was aborted: back home with the best gains so far
            yield from self._back_home(result)
        if self._on_controller != gains:
            yield from self.write_gains(gains, result.rated_current)
        if self.loop == "position":
            trial = yield from self._position_trial(number, gains)
        else:
            trial = yield from self._speed_trial(number, gains)
        tried[gains] = trial.score
        result.trials.append(trial)
        if result.best is None or trial.score < result.best.score:
            result.best = trial
        yield Note(TrialDone(trial, result.best))
        return trial

    def _back_home(self, result: TuneResult) -> Procedure[None]:
        """After an aborted trial (control off, the motor coasted): control on with the best gains
        so far (the starting ones if none measured), and back to the start position if the
        coast took it past half the travel, so the next trial starts inside the envelope."""
        best = result.best if result.best is not None and result.best.figures is not None else None
        safe = best.gains if best is not None else result.start_gains
        if self._on_controller != safe:
            yield from self.write_gains(safe, result.rated_current)
        yield from self.motor.hold()
        self._released_by_us = False
        here = (yield from self._read_state()).device_position
        if abs(here - self._home) > self.envelope.travel / 2:
            yield from self.motor.move_to(self._home, rpm=self.envelope.max_rpm)
            yield from self._wait_at_rest(guard=False)  # coming back from outside: no abort on the way

    def _read_state(self) -> Procedure[MotorState]:
        """A reading; one that fails after the core's retries is asked once more after a pause
        (a loaded host or a noisy line): "does not answer" is two failures in a row."""
        try:
            return (yield from self.motor.read_state())
        except NoAnswer:
            yield Wait(READ_AGAIN_AFTER)
            return (yield from self.motor.read_state())

    def _read_speed(self) -> Procedure[float]:
        try:
            return float((yield from self.motor.read_speed()))
        except NoAnswer:
            yield Wait(READ_AGAIN_AFTER)
            return float((yield from self.motor.read_speed()))

    def _outside(self, position: float, speed: float, current: float) -> str | None:
        env = self.envelope
        if abs(position - self._home) > env.travel:
            return f"left the envelope: {position - self._home:+.1f}° from the start (travel ±{env.travel:g}°)"
        if abs(speed) > env.max_rpm * SPEED_MARGIN + 1:
            return f"too fast: {abs(speed):g} RPM (max {env.max_rpm:g})"
        if current > env.max_current:
            return f"too much current: {current:g} A (max {env.max_current:g} A)"
        return None

    def _abort(
        self, number: int, gains: Gains, why: str, samples: list[tuple[float, float]], start: float, target: float
    ) -> Procedure[Trial]:
        yield from self.motor.release()  # control off at once
        self._released_by_us = True
        yield from self._wait_at_rest()
        return Trial(number, gains, None, math.inf, why, tuple(samples), start, target)

    def _wait_at_rest(self, guard: bool = True) -> Procedure[bool]:
        """Read until at rest (two readings under 1 RPM; False after SETTLE_PATIENCE); with
        `guard`, a reading outside the envelope turns control off."""
        began = yield Now()
        still = 0
        while (yield Now()) - began < SETTLE_PATIENCE:
            state = yield from self._read_state()
            guarded = guard and not self._released_by_us
            reason = self._outside(state.device_position, 0.0, state.current) if guarded else None
            if reason is not None:
                yield from self.motor.release()
                self._released_by_us = True
            still = still + 1 if abs(state.speed) < 1.0 else 0
            if still >= 2:
                return True
            yield Wait(0.02)
        return False

    def _position_trial(self, number: int, gains: Gains) -> Procedure[Trial]:
        """A step out (half the travel) and one back to the start: a response can differ with
        the direction (backlash, friction, gravity), so a set is judged by its worse leg."""
        step = self.envelope.travel / 2
        legs: list[Trial] = []
        for target in (self._home + step, self._home):
            leg = yield from self._position_leg(number, gains, target)
            if leg.aborted is not None:
                return leg
            legs.append(leg)
        worse = max(legs, key=lambda leg: leg.score)
        first = legs[0]
        return Trial(number, gains, worse.figures, worse.score, None, first.samples, first.start, first.target)

    def _position_leg(self, number: int, gains: Gains, target: float) -> Procedure[Trial]:
        here = (yield from self._read_state()).device_position
        if abs(target - here) < MIN_STEP:  # already there (a leg after an abort): no step to measure
            target = self._home + self.envelope.travel / 2 if target == self._home else self._home
        yield from self.motor.move_to(target, rpm=self.envelope.max_rpm)
        began = yield Now()
        samples: list[tuple[float, float]] = []
        times: list[float] = []
        values: list[float] = []
        currents: list[float] = []
        while (now := (yield Now())) - began < self.window:
            state = yield from self._read_state()
            t = now - began
            samples.append((t, state.device_position))
            times.append(t)
            values.append(state.device_position)
            currents.append(state.current)
            yield Note(TrialSample(number, t, state.device_position, state))
            why = self._outside(state.device_position, state.speed, state.current)
            if why is None and len(values) > 3:
                crossing = response_figures(times, values, here, target, min_band=0.5).oscillations
                if crossing >= OSCILLATION_CROSSINGS:
                    why = f"oscillating ({crossing} crossings of the target)"
            if why is not None:
                return (yield from self._abort(number, gains, why, samples, here, target))
            yield Wait(SAMPLE_PAUSE)
        if not (yield from self._wait_at_rest()):
            still = "still moving after the trial (oscillating)"
            return (yield from self._abort(number, gains, still, samples, here, target))
        figures = response_figures(times, values, here, target, currents, min_band=0.5)
        cost, _ = score(figures, self.goal, self.window)
        return Trial(number, gains, figures, cost, None, tuple(samples), here, target)

    def _speed_trial(self, number: int, gains: Gains) -> Procedure[Trial]:
        here = (yield from self._read_state()).device_position
        forward = here <= self._home
        room = self._home + self.envelope.travel - here if forward else here - (self._home - self.envelope.travel)
        window = min(self.window, speed_window(self.envelope, room))
        rpm = 0.8 * self.envelope.max_rpm * (1 if forward else -1)
        yield from self.motor.run(rpm, ramp_seconds=0.1)
        began = yield Now()
        samples: list[tuple[float, float]] = []
        times: list[float] = []
        values: list[float] = []
        currents: list[float] = []
        while (now := (yield Now())) - began < window:
            state = yield from self._read_state()
            speed = yield from self._read_speed()
            t = now - began
            samples.append((t, speed))
            times.append(t)
            values.append(speed)
            currents.append(state.current)
            yield Note(TrialSample(number, t, speed, state))
            why = self._outside(state.device_position, speed, state.current)
            if why is not None:
                return (yield from self._abort(number, gains, why, samples, 0.0, rpm))
            yield Wait(SAMPLE_PAUSE)
        yield from self.motor.stop(ramp_seconds=0.1)
        figures = response_figures(times, values, 0.0, rpm, currents, min_band=1.0)
        cost, _ = score(figures, self.goal, window)
        return Trial(number, gains, figures, cost, None, tuple(samples), 0.0, rpm)


def _gains_text(gains: Gains) -> str:
    return ", ".join(f"{name} {value}" for name, value in zip(GAIN_FIELDS, gains, strict=True))


def tune(
    motor: MotorProcedures,
    loop: str = "position",
    goal: str | None = None,
    max_overshoot: float | None = None,
    max_settling: float | None = None,
    travel: float = DEFAULT_TRAVEL,
    max_rpm: float = DEFAULT_MAX_RPM,
    max_current: float = DEFAULT_MAX_CURRENT,
    trials: int = DEFAULT_TRIALS,
    apply: bool = False,
) -> Procedure[TuneResult]:
    """Tune a loop of `motor` (see Tuner); the procedure behind Motor.tune()."""
    tuner = Tuner(
        motor, loop, make_goal(goal, max_overshoot, max_settling), Envelope(travel, max_rpm, max_current), trials
    )
    return (yield from tuner.run(apply=apply))


__all__ = [
    "DEFAULT_MAX_CURRENT",
    "DEFAULT_MAX_RPM",
    "DEFAULT_TRAVEL",
    "DEFAULT_TRIALS",
    "Envelope",
    "GOALS",
    "Goal",
    "LOOPS",
    "Trial",
    "TrialDone",
    "TrialSample",
    "TrialStarted",
    "TuneRefused",
    "TuneResult",
    "TuneStopped",
    "Tuner",
    "check_envelope",
    "make_goal",
    "neighbours",
    "score",
    "tune",
]
