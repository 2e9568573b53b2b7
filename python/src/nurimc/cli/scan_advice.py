"""What `scan` says after its table: shared IDs and what to do about them, the wiring checklist
when nothing answered, and `--expect N`'s verdict (issue 38, New motors)."""

from __future__ import annotations

from typing import Any

import typer

from ..procedures.collisions import shared_message
from .common import EXIT_DEVICE, err
from .i18n import tr

#: Said when no controller answered: the causes, most likely first (docs/troubleshooting.md).
WIRING_CHECKLIST = (
    "no controller answered. Check, in this order:",
    "  1. power: the controller's supply is on (its LED lights)",
    "  2. wiring: A to A, B to B (swap them if unsure) and a common ground between adapter and controller",
    "  3. port: the adapter's device (ls /dev/ttyUSB* /dev/ttyACM*) is the --port given",
    "  4. termination: a 120 ohm resistor at each end of a long bus",
    "then scan again; nurimc scan --expect N exits 1 when fewer than N controllers answer",
)


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
