"""Product profiles for the simulator: spec/profiles.json by default, or a file of the same shape.

A profile says how a product behaves beyond the wire format: its factory gains and rated
current, its EEPROM busy window (what a host should wait; the simulator's own busy time is
--eeprom-ms) and what a motion frame with speed 0 does (`ignore`: outside the document's
range 1-65533, so the frame is dropped; `stop`: the motor holds where it is).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..protocol import PRODUCTS
from ..protocol.host import PROFILES
from .plant import PLANT_KEYS, Plant, PlantError, plant_from
from .settings import setting_problem

SPEED_ZERO_CHOICES = ("ignore", "stop")
_GAIN_SETTINGS = {
    "position_kp": "position_kp",
    "position_ki": "position_ki",
    "position_kd": "position_kd",
    "speed_kp": "speed_kp",
    "speed_ki": "speed_ki",
    "speed_kd": "speed_kd",
    "rated_current": "speed_rated_current",
}


@dataclass(frozen=True)
class SimProfile:
    product: str
    speed_zero: str
    busy_window: float
    factory_defaults: dict[str, int]
    plant: Plant | None = None  # the motor and load this product's controllers stand for (sim/plant.py)


def default_profiles() -> dict[str, SimProfile]:
    """The profiles of spec/profiles.json (as generated into nurimc.protocol)."""
    return {
        key: SimProfile(key, p.speed_zero, p.busy_window, dict(p.factory_defaults))
        for key, p in PROFILES.items()
        if key in PRODUCTS
    }


def load_profiles(path: str | Path) -> dict[str, SimProfile]:
    """Profiles from a file shaped like spec/profiles.json; a product it leaves out keeps the
    spec's profile, a key it leaves out keeps the spec's value. ValueError (one line, naming
    the file and the key) if anything is wrong."""
    where = Path(path)
    try:
        data = json.loads(where.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ValueError(f"--profile {where}: cannot read it: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ValueError(f"--profile {where}: not JSON: {exc}") from None
    entries = data.get("profiles") if isinstance(data, dict) else None
    if not isinstance(entries, dict):
        raise ValueError(f"--profile {where}: no 'profiles' object (see spec/profiles.json for the shape)")
    profiles = default_profiles()
    for product, entry in entries.items():
        if product not in PRODUCTS:
            raise ValueError(f"--profile {where}: unknown product {product!r}; use {', '.join(PRODUCTS)}")
        if not isinstance(entry, dict):
            raise ValueError(f"--profile {where}: profiles.{product} is not an object")
        profiles[product] = _merge(profiles[product], entry, f"--profile {where}: profiles.{product}")
    return profiles


def _merge(base: SimProfile, entry: dict[str, Any], where: str) -> SimProfile:
    speed_zero = entry.get("speed_zero", base.speed_zero)
    if speed_zero not in SPEED_ZERO_CHOICES:
        raise ValueError(f"{where}.speed_zero is {speed_zero!r}; use one of {', '.join(SPEED_ZERO_CHOICES)}")
    busy = entry.get("busy_window_s", base.busy_window)
    if isinstance(busy, bool) or not isinstance(busy, (int, float)) or not (math.isfinite(busy) and 0 <= busy <= 10):
        raise ValueError(f"{where}.busy_window_s is {busy!r}; use seconds, 0..10")
    defaults = dict(base.factory_defaults)
    given = entry.get("factory_defaults", {})
    if not isinstance(given, dict):
        raise ValueError(f"{where}.factory_defaults is not an object")
    for key, value in given.items():
        if key not in _GAIN_SETTINGS:
            raise ValueError(f"{where}.factory_defaults: unknown key {key!r}; known: {', '.join(_GAIN_SETTINGS)}")
        problem = setting_problem(_GAIN_SETTINGS[key], value)
        if problem is not None:
            raise ValueError(f"{where}.factory_defaults.{key}: {problem}")
        defaults[key] = value
    plant = base.plant
    if "plant" in entry:
        given_plant = entry["plant"]
        if not isinstance(given_plant, dict):
            raise ValueError(f"{where}.plant is not an object (keys: {', '.join(PLANT_KEYS)})")
        try:
            plant = plant_from(given_plant, f"{where}.plant", base.plant)
        except PlantError as error:
            raise ValueError(str(error)) from None
    return SimProfile(base.product, speed_zero, float(busy), defaults, plant)
