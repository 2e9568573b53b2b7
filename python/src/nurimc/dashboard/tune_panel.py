"""The console's Auto-tune (issue 35): the `tune` and `tune_cancel` ops and the worker's handler.

The page sends `{"op": "tune", "id", "loop", "goal", "travel", "max_rpm", "max_current",
"trials", "max_overshoot"?, "max_settling"?}`; the bus worker runs nurimc.procedures.tuning's procedure
(the starting gains written back at the end: the page applies the chosen gains with `set`, after
the user clicks Apply) and publishes `{"type": "tune", ...}` events: each trial as it starts and
ends (its samples, figures and score: a row in the step-response runs). `tune_cancel` is taken
out of band (the worker is busy with the tune): the tune stops at its next reading and writes
the starting gains back; an emergency stop ends it the same way.
"""

from __future__ import annotations

import threading
from typing import Any

from ..errors import NurimcError
from ..procedures.tuning import Envelope, TrialDone, TrialStarted, Tuner, TuneStopped, make_goal
from . import commands as c

Tune = c.Tune
TuneCancel = c.TuneCancel
parse_tune = c._tune


class TuneCancelled(Exception):
    """The page asked to stop the tune (thrown into the tuner: it writes the starting gains back)."""


CANCEL = threading.Event()


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


__all__ = ["CANCEL", "Tune", "TuneCancel", "TuneCancelled", "cancel", "parse_tune", "run_tune"]
