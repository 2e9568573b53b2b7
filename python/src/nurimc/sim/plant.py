"""Plant parameters: a simulated controller that stands for a different motor and load.

Keys (docs/simulator.md, Plant parameters):

- `inertia`, `viscous`, `coulomb`: multiples of today's model (1 = today). `inertia` divides
  every acceleration (the drive's, and the friction's, since friction is a torque); `viscous`
  and `coulomb` multiply the two friction torques.
- `backlash`: degrees of play at the output. The position the controller reads (and reports)
  follows the motor only once the play is taken up: a play (hysteresis) element of this width.
- `noise`: degrees, the standard deviation of the position reading (Gaussian, a new sample
  each physics step, seeded: the same run gives the same noise).
- `delay`: seconds of dead time of the drive: the current the speed loop asks for is applied
  this much later.

The gains keep today's scaling: a plant changes the motor, not the controller.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

PLANT_KEYS = ("inertia", "viscous", "coulomb", "backlash", "noise", "delay")
# what each key accepts: (lowest, highest) and what it means, for the one-line errors
_RANGES = {
    "inertia": (0.01, 1000.0, "a multiple of today's inertia (1 = today)"),
    "viscous": (0.0, 1000.0, "a multiple of today's viscous friction (1 = today)"),
    "coulomb": (0.0, 1000.0, "a multiple of today's dry friction (1 = today)"),
    "backlash": (0.0, 90.0, "degrees of play at the output"),
    "noise": (0.0, 90.0, "degrees (std) of noise on the position reading"),
    "delay": (0.0, 0.5, "seconds of drive dead time"),
}


class PlantError(ValueError):
    """A plant parameter is malformed or out of range; the message says how to write it."""


@dataclass(frozen=True)
class Plant:
    inertia: float = 1.0
    viscous: float = 1.0
    coulomb: float = 1.0
    backlash: float = 0.0
    noise: float = 0.0
    delay: float = 0.0

    def is_default(self) -> bool:
        return self == Plant()

    def describe(self) -> str:
        default = Plant()
        names = [f.name for f in fields(self) if getattr(self, f.name) != getattr(default, f.name)]
        changed = [f"{name}={getattr(self, name):g}" for name in names]
        return ",".join(changed) or "default"


def check_value(key: str, value: object, where: str) -> float:
    if key not in _RANGES:
        raise PlantError(f"{where}: unknown plant key {key!r}; use {', '.join(PLANT_KEYS)}")
    low, high, meaning = _RANGES[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PlantError(f"{where}: {key}={value!r} is not a number; give {meaning}, {low:g}..{high:g}")
    if not low <= value <= high:
        raise PlantError(f"{where}: {key}={value:g} is out of range; give {meaning}, {low:g}..{high:g}")
    return float(value)


def plant_from(values: dict[str, object], where: str, base: Plant | None = None) -> Plant:
    """A Plant from {key: number} (a profile file's "plant" object), over `base`."""
    checked = {key: check_value(key, value, where) for key, value in values.items()}
    return replace(base or Plant(), **checked)


def parse_plant(text: str) -> tuple[int, Plant]:
    """`ID:KEY=VALUE[,KEY=VALUE...]` (the sim's --plant) -> (ID, Plant)."""
    ident, sep, rest = text.partition(":")
    example = "e.g. 1:inertia=2,backlash=0.5"
    if not sep or not rest.strip():
        raise PlantError(f"--plant {text!r}: write ID:KEY=VALUE[,KEY=VALUE...], {example}")
    try:
        if not ident.strip().isascii():
            raise ValueError
        device_id = int(ident.strip(), 0)
    except ValueError:
        raise PlantError(f"--plant {text!r}: the ID {ident!r} is not a number; {example}") from None
    if not 0 <= device_id <= 254:
        raise PlantError(f"--plant {text!r}: ID {device_id} is out of range; use 0..254")
    values: dict[str, object] = {}
    for item in rest.split(","):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq:
            raise PlantError(f"--plant {text!r}: {item!r} is not KEY=VALUE; {example}")
        try:
            number: object = float(value.strip()) if value.strip().isascii() else value
        except ValueError:
            number = value.strip()
        values[key] = number
    return device_id, plant_from(values, f"--plant {text!r}")


def apply_plants(controllers: Sequence[Any], texts: Sequence[str]) -> None:
    """Each `ID:KEY=VALUE,...` onto the controllers with that ID (PlantError if none has it)."""
    for text in texts:
        device_id, plant = parse_plant(text)
        chosen = [c for c in controllers if c.id == device_id]
        if not chosen:
            have = ", ".join(str(c.id) for c in controllers)
            raise PlantError(f"--plant {text!r}: no controller has ID {device_id} (IDs: {have})")
        for controller in chosen:
            controller.set_plant(plant)


__all__ = ["PLANT_KEYS", "Plant", "PlantError", "apply_plants", "check_value", "parse_plant", "plant_from"]
