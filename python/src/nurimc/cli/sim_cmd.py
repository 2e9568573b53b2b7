"""`nurimc sim`: simulated controllers on a pseudo-terminal and/or TCP (see nurimc.sim.cli)."""

from __future__ import annotations

import typer

from ..sim.cli import sim


def register(app: typer.Typer) -> None:
    app.command(name="sim")(sim)
