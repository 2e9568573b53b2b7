"""`nurimc inspect FILE.mcap` (what a recording holds) and `nurimc export FILE.mcap --csv OUT`
(its samples as CSV); `replay` shows the same summary for an MCAP file (nurimc.recording.summary)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import typer

from .common import emit, fail, options, out, table
from .i18n import tr


def show_summary(o: Any, path: str) -> None:
    """The summary of an MCAP recording: a table of topics, then the span and the motors."""
    from ..recording.summary import RecordingError, summarize

    try:
        summary = summarize(path)
    except OSError as error:
        fail(f"{path}: {error.strerror or error}")
    except RecordingError as error:
        fail(str(error))
    if o.json:
        emit(o, summary.as_dict())
        return
    rows = table(f"{path}: {summary.messages} messages over {summary.seconds:.3f} s", "topic", "schema", "messages")
    for t in summary.topics:
        rows.add_row(t.topic, t.schema, str(t.count))
    emit(o, None, rows)
    motors = ", ".join(summary.motors) or "-"
    ids = ", ".join(str(i) for i in summary.frame_ids) or "-"
    out.print(tr(f"motors (joint names): {motors}; controller IDs in the frames: {ids}"), soft_wrap=True, markup=False)


def inspect(
    ctx: typer.Context,
    recording: str = typer.Argument(..., help="An MCAP recording (nurimc record, ros2 bag)."),
) -> None:
    """Summarise an MCAP recording: topics, message counts, time span, motors.

    Example: nurimc inspect run.mcap
    """
    show_summary(options(ctx), recording)


def export(
    ctx: typer.Context,
    recording: str = typer.Argument(..., help="An MCAP recording (nurimc record, ros2 bag)."),
    csv_path: str = typer.Option(..., "--csv", help="The CSV file to write ('-': stdout)."),
    topic: str = typer.Option(None, "--topic", help="Only this JointState topic (default: every one)."),
) -> None:
    """Write a recording's joint samples as CSV: one row per sample, time in seconds, units in the header.

    Example: nurimc export run.mcap --csv run.csv
    """
    from ..recording.summary import RecordingError, export_csv

    o = options(ctx)
    try:
        if csv_path == "-":
            rows, joints = export_csv(recording, sys.stdout, topic)
        else:
            target = Path(csv_path)
            partial = target.with_name(f".{target.name}.partial")
            with partial.open("w", encoding="utf-8", newline="") as stream:
                rows, joints = export_csv(recording, stream, topic)
            partial.replace(target)  # a failed export leaves no half CSV behind
    except OSError as error:
        fail(f"{error.filename or recording}: {error.strerror or error}")
    except RecordingError as error:
        if csv_path != "-":
            Path(csv_path).with_name(f".{Path(csv_path).name}.partial").unlink(missing_ok=True)
        fail(str(error))
    if csv_path != "-":
        emit(
            o,
            {"file": csv_path, "rows": rows, "joints": joints},
            f"wrote {csv_path}: {rows} samples of {len(joints)} joint(s)",
        )


def register(app: typer.Typer) -> None:
    app.command()(inspect)
    app.command()(export)
