"""The console's Auto-tune (issue 35): the `tune` and `tune_cancel` ops and the worker's handler.

The page sends `{"op": "tune", "id", "loop", "goal", "travel", "max_rpm", "max_current",
"trials", "max_overshoot"?, "max_settling"?}`; the bus worker runs nurimc.tuning's procedure
(the starting gains written back at the end: the page applies the chosen gains with `set`, after
the user clicks Apply) and publishes `{"type": "tune", ...}` events: each trial as it starts and
ends (its samples, figures and score: a row in the step-response runs). `tune_cancel` is taken
out of band (the worker is busy with the tune): the tune stops at its next reading and writes
the starting gains back; an emergency stop ends it the same way.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

from ..errors import NurimcError
from ..tuning import (
    DEFAULT_MAX_CURRENT,
    DEFAULT_MAX_RPM,
    DEFAULT_TRAVEL,
    GOALS,
    Envelope,
    TrialDone,
    TrialStarted,
    Tuner,
    TuneRefused,
    TuneStopped,
    make_goal,
)

#: the most trials the console asks for at once (each takes a second or two)
MAX_TRIALS = 60


@dataclass(frozen=True, slots=True)
class Tune:
    id: int
    loop: str
    goal: str | None
    travel: float
    max_rpm: float
    max_current: float
    trials: int
    max_overshoot: float | None
    max_settling: float | None


@dataclass(frozen=True, slots=True)
class TuneCancel:
    pass


class TuneCancelled(Exception):
    """The page asked to stop the tune (thrown into the tuner: it writes the starting gains back)."""


CANCEL = threading.Event()


def parse_tune(m: dict[str, Any]) -> Tune:
    """The `tune` op, checked as the library checks it (nothing reaches the bus when refused)."""
    from . import commands as c

    device_id = c._device_id(m)
    loop = m.get("loop", "position")
    goal = m.get("goal")
    if goal is not None and goal not in GOALS:
        raise c.CommandError(f"tune: goal must be one of {', '.join(GOALS)}, got {c._show(goal)}")
    trials = c._number(m, "trials", 12)
    if trials != int(trials) or not 2 <= trials <= MAX_TRIALS:
        raise c.CommandError(f"tune: trials must be a whole number 2..{MAX_TRIALS}, got {c._show(m.get('trials'))}")
    command = Tune(
        device_id,
        loop if isinstance(loop, str) else "",
        goal,
        c._number(m, "travel", DEFAULT_TRAVEL),
        c._number(m, "max_rpm", DEFAULT_MAX_RPM),
        c._number(m, "max_current", DEFAULT_MAX_CURRENT),
        int(trials),
        c._optional_number(m, "max_overshoot"),
        c._optional_number(m, "max_settling"),
    )
    try:
        _tuner_checks(command)
    except TuneRefused as refused:
        raise c.CommandError(f"tune: {refused}") from None
    return command


def _tuner_checks(t: Tune) -> None:
    from ..tuning import check_envelope

    make_goal(t.goal, t.max_overshoot, t.max_settling)
    check_envelope(t.loop, Envelope(t.travel, t.max_rpm, t.max_current), t.trials)


def cancel() -> dict[str, Any]:
    """Out of band: ask the running tune to stop."""
    CANCEL.set()
    return {"cancelling": True}


def _trial_event(device_id: int, event: TrialDone) -> dict[str, Any]:
    trial = event.trial
    return {
        "type": "tune",
        "event": "trial",
        "id": device_id,
        **trial.as_dict(),
        "times": [round(t, 4) for t, _ in trial.samples],
        "values": [v for _, v in trial.samples],
        "best": None if event.best is None else event.best.number,
    }


def run_tune(worker: Any, t: Tune) -> dict[str, Any]:
    """The worker's handler for a Tune command (runs on the bus thread)."""
    motor = worker.motor(t.id)
    tuner = Tuner(
        motor.procedures,
        t.loop,
        make_goal(t.goal, t.max_overshoot, t.max_settling),
        Envelope(t.travel, t.max_rpm, t.max_current),
        t.trials,
    )
    CANCEL.clear()
    worker._wrote_eeprom(t.id, " (auto-tune gains)")

    def progress(event: object) -> None:
        worker._check_estop()  # an emergency stop ends the tune: the gains are written back
        if CANCEL.is_set():
            raise TuneCancelled
        if isinstance(event, TrialStarted):
            worker.publish(
                {
                    "type": "tune",
                    "event": "start",
                    "id": t.id,
                    "trial": event.number,
                    "budget": event.budget,
                    "gains": dict(zip(("kp", "ki", "kd"), event.gains, strict=True)),
                }
            )
        elif isinstance(event, TrialDone):
            worker.publish(_trial_event(t.id, event))
        else:
            state = getattr(event, "state", None)
            if state is not None:
                worker._plot(state)

    try:
        result = worker.bus.run(tuner.run(apply=False), on_note=progress)
    except TuneCancelled:
        done = tuner.result.as_dict() if tuner.result is not None else {}
        return {"id": t.id, "cancelled": True, "restored": bool(tuner.restored), **done}
    except TuneStopped as stopped:
        raise NurimcError(str(stopped)) from None
    finally:
        CANCEL.clear()
    return {"id": t.id, "cancelled": False, "restored": True, **result.as_dict()}


__all__ = ["CANCEL", "MAX_TRIALS", "Tune", "TuneCancel", "TuneCancelled", "cancel", "parse_tune", "run_tune"]
