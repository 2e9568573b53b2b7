"""`nurimc sim`: simulated controllers on a pseudo-terminal and/or TCP (see nurimc.sim.cli)."""

from __future__ import annotations

from ..sim.cli import sim as _sim
from .app import app

sim = app.command(name="sim")(_sim)
