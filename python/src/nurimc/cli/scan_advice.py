"""What `scan` says after its table: shared IDs and what to do about them, the wiring checklist
when nothing answered, and `--expect N`'s verdict (issue 38, New motors)."""

from __future__ import annotations

from typing import Any

import typer

from ..procedures.collisions import shared_message
from .common import EXIT_DEVICE, err
from .i18n import tr
from .messages import WIRING_CHECKLIST


def scan_advice(found: list[Any], expect: int) -> None:
    """Lines on stderr after the scan's table; exit 1 (EXIT_DEVICE) when `expect` is not met."""
    for f in found:
        if f.collision:
            err.print(tr("note:") + " " + tr(shared_message(f.id, f.baudrate)), soft_wrap=True, markup=False)
    if not found:
        for line in WIRING_CHECKLIST:
            err.print(tr(line), soft_wrap=True, markup=False)
    if expect and len(found) < expect:
        err.print(
            tr("error:") + " " + tr(f"expected {expect} controller(s), found {len(found)}"),
            soft_wrap=True,
            markup=False,
        )
        raise typer.Exit(EXIT_DEVICE)
