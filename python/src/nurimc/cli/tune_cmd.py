"""tune: find a loop's gains on the motor itself (nurimc.procedures.tuning, docs/tuning.md)."""

from __future__ import annotations

import datetime
import os
import sys
from pathlib import Path
from typing import Any

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from ..drivers.sync import Bus
from ..errors import NurimcError
from ..procedures import config
from ..procedures.journal import RestoreJournal, incomplete_message, state_dir
from ..procedures.tuning import (
    DEFAULT_MAX_CURRENT,
    DEFAULT_MAX_RPM,
    DEFAULT_TRAVEL,
    DEFAULT_TRIALS,
    GOALS,
    Envelope,
    Gains,
    Trial,
    TrialDone,
    TrialStarted,
    Tuner,
    TuneRefused,
    TuneResult,
    TuneStopped,
    check_envelope,
    make_goal,
)
from ..protocol.host import LIMITS
from .common import (
    EXIT_DEVICE,
    EXIT_USAGE,
    Number,
    Options,
    emit,
    err,
    fail,
    motor_for,
    note,
    one_id,
    open_bus,
    options,
    table,
)
from .i18n import tr

OVERSHOOT = Number("--max-overshoot", 0, 100, "%")
SETTLING = Number("--max-settling", 0.01, 30, "s")
TRAVEL = Number("--travel", 0.1, 655, "°")
MAX_RPM = Number("--max-rpm", 1, LIMITS["speed_rpm_max"], "RPM")
MAX_CURRENT = Number("--max-current", 0.1, 25.4, "A")
TRIALS = Number("--trials", 2, 500, whole=True)


def tune(
    ctx: typer.Context,
    loop: str = typer.Option("position", "--loop", help="The loop to tune: position or speed."),
    goal: str | None = typer.Option(
        None, "--goal", help="stiff, smooth or no-overshoot (the default when no limit is given)."
    ),
    max_overshoot: float | None = typer.Option(
        None, "--max-overshoot", help=f"Largest overshoot allowed ({OVERSHOOT.allowed}).", parser=OVERSHOOT
    ),
    max_settling: float | None = typer.Option(
        None, "--max-settling", help=f"Longest settling time allowed ({SETTLING.allowed}).", parser=SETTLING
    ),
    travel: float = typer.Option(
        DEFAULT_TRAVEL,
        "--travel",
        help=f"Degrees the motor may move either side of here ({TRAVEL.allowed}).",
        parser=TRAVEL,
    ),
    max_rpm: float = typer.Option(
        DEFAULT_MAX_RPM, "--max-rpm", help=f"Fastest a trial may turn ({MAX_RPM.allowed}).", parser=MAX_RPM
    ),
    max_current: float = typer.Option(
        DEFAULT_MAX_CURRENT,
        "--max-current",
        help=f"Most current a trial may draw ({MAX_CURRENT.allowed}).",
        parser=MAX_CURRENT,
    ),
    trials: int = typer.Option(
        DEFAULT_TRIALS,
        "--trials",
        help=f"Trial budget, the first measures today's gains ({TRIALS.allowed}).",
        parser=TRIALS,
    ),
    apply: bool = typer.Option(False, "--apply", help="Write the chosen gains without asking."),
) -> None:
    """Tune the position or speed loop's gains with small steps on the motor.

    The starting gains are read first and written back on Ctrl+C, an error or a lost port;
    the chosen gains are written with --apply, otherwise after you confirm.

    Example: nurimc --port /dev/ttyUSB0 --id 1 tune --loop position --goal no-overshoot --travel 20
    """
    o = options(ctx)
    device_id = one_id(o)
    try:  # every check before the port is opened: nothing moves on a refused tune
        chosen_goal = make_goal(goal, max_overshoot, max_settling)
        envelope = Envelope(travel, max_rpm, max_current)
        check_envelope(loop, envelope, trials)
        with open_bus(o) as bus:
            motor = motor_for(bus, o, device_id)
            tuner = Tuner(motor.procedures, loop, chosen_goal, envelope, trials)
            _run(o, bus, tuner, device_id, apply)
    except TuneRefused as refused:
        fail(str(refused), EXIT_USAGE)


def _journal(o: Options, bus: Bus, tuner: Tuner, device_id: int) -> tuple[RestoreJournal, Path | None]:
    """Every setting of the motor saved before the first write, and the restore journal marked:
    a tune cut off by a lost port is found next time (`nurimc restore FILE` writes it back)."""
    journal = RestoreJournal(o.port or os.environ.get("NURIMC_PORT", ""))
    earlier = journal.pending(device_id)
    if earlier is not None:
        note(f"{incomplete_message(earlier)}; tuning now replaces it with a new copy of today's settings")
    if not journal.enabled:
        return journal, None
    document = bus.run(config.backup([tuner.motor]))
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%S")
    file = state_dir() / "tune" / f"id{device_id}-{stamp}.json"
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        config.save_backup(document, file)
        journal.begin([device_id], file)
    except OSError as error:
        journal.enabled = False
        note(
            f"cannot keep the starting settings in {file.parent} ({error.strerror or error}): a lost port will "
            "not be remembered; set NURIMC_STATE_DIR to a writable folder"
        )
        return journal, None
    return journal, file


def _run(o: Options, bus: Bus, tuner: Tuner, device_id: int, apply: bool) -> None:
    journal, saved = _journal(o, bus, tuner, device_id)
    shown = not o.json and sys.stderr.isatty()
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err,
        transient=True,
        disable=not shown,
    )
    task = progress.add_task(tr("tuning"), total=tuner.budget)

    def on_note(event: Any) -> None:
        if isinstance(event, TrialStarted):
            progress.update(task, description=tr(f"trial {event.number}: {_gains(event.gains)}"))
        elif isinstance(event, TrialDone):
            progress.update(task, completed=event.trial.number)

    try:
        with progress:
            result = bus.run(tuner.run(apply=apply), on_note=on_note)
    except KeyboardInterrupt:
        if tuner.restored:
            journal.done([device_id])
            err.print(tr(f"stopped: restored the starting gains {_gains(_start(tuner))} (read back)"))
        else:
            _kept(saved, o)
        raise
    except TuneStopped as stopped:
        if stopped.restored:
            journal.done([device_id])
        else:
            _kept(saved, o)
        fail(str(stopped), EXIT_DEVICE)
    except NurimcError:
        _kept(saved, o)
        raise
    journal.done([device_id])
    _show(o, result, device_id)
    if result.applied or result.best is None:
        return
    if result.best.gains == result.start_gains:
        note("the starting gains scored best: nothing to change")
        return
    if o.json or not sys.stdin.isatty():
        note("not applied: run with --apply to write the chosen gains (the starting gains are on the controller)")
        return
    if not typer.confirm(tr(f"Write {_gains(result.best.gains)} to ID {device_id}?")):
        err.print(tr("not applied: answered no (the starting gains stay)"))
        return
    bus.run(tuner.apply_best())
    err.print(tr(f"ID {device_id}: wrote {_gains(result.best.gains)} (read back)"))


def _start(tuner: Tuner) -> Gains:
    return tuner.result.start_gains if tuner.result is not None else (0, 0, 0)


def _kept(saved: Path | None, o: Options) -> None:
    if saved is not None:
        port = o.port or os.environ.get("NURIMC_PORT", "PORT")
        err.print(
            tr(
                f"the starting settings are in {saved}: once the motor answers, "
                f"run: nurimc --port {port} restore {saved}"
            ),
            markup=False,
            soft_wrap=True,
        )


def _gains(gains: Gains) -> str:
    kp, ki, kd = gains
    return f"kp {kp}, ki {ki}, kd {kd}"


def _cells(trial: Trial | None) -> list[str]:
    if trial is None or trial.figures is None:
        return ["-"] * 5
    f = trial.figures
    return [
        f"{f.overshoot:g}",
        "-" if f.settling_time is None else f"{f.settling_time:.3f}",
        "-" if f.rise_time is None else f"{f.rise_time:.3f}",
        f"{f.current_peak:g}",
        f"{f.final_error:g}",
    ]


def _show(o: Options, result: TuneResult, device_id: int) -> None:
    figures = ("overshoot %", "settling s", "rise s", "current A", "final error")
    rows = table(f"ID {device_id}: {result.loop} loop, goal {result.goal.name}", "trial", "gains", *figures, "result")
    for trial in result.trials:
        outcome = trial.aborted or ("best" if trial is result.best else "")
        rows.add_row(str(trial.number), _gains(trial.gains), *_cells(trial), outcome)
    summary = table("chosen against starting gains", "", "gains", *figures)
    summary.add_row("start", _gains(result.start_gains), *_cells(result.start))
    if result.best is not None:
        summary.add_row("chosen", _gains(result.best.gains), *_cells(result.best))
    document = {"id": device_id, **result.as_dict()}
    emit(o, document, rows)
    if not o.json:
        emit(o, None, summary)
        for limit in result.unmet:
            note(f"limit not met: {limit} (the best found is shown)")


def register(app: typer.Typer) -> None:
    app.command()(tune)


__all__ = ["GOALS", "register", "tune"]
