"""`serial.serial_for_url("sim://?ids=0,1&baud=9600&product=mc&wire_timing=0&motor=3@57600")`.

Each URL makes a new bus (reach it as `port.bus`). Parameters: ids (list or count), baud,
product, motor (repeatable ID@RATE or ID@RATE:PRODUCT), wire_timing, state (directory), seed, and the fault
options drop_rate, flip_rate, noise_rate, delay_ms, miss_rate, same_sum_rate, dup_rate, echo; speed_zero (ignore or
stop) and eeprom_ms. `ids=1` is the controller at ID 1 (`ids=0-3` a range); no ids: ID 0.
"""

from __future__ import annotations

import math
import urllib.parse
from typing import Any

import serial

from ..bus import SimBus
from ..faults import FaultConfig
from ..options import OptionError, check_baud, parse_bool, parse_ids, parse_motor
from ..plant import PlantError, apply_plants
from ..port import SimSerial
from ..profile import SPEED_ZERO_CHOICES
from ..store import StateError

_FLOAT_FAULTS = (
    "drop_rate",
    "flip_rate",
    "noise_rate",
    "delay_ms",
    "delay_rate",
    "miss_rate",
    "same_sum_rate",
    "dup_rate",
)
_KNOWN = {
    "ids",
    "baud",
    "product",
    "motor",
    "wire_timing",
    "state",
    "seed",
    "echo",
    "speed_zero",
    "eeprom_ms",
    "plant",
    *_FLOAT_FAULTS,
}


def bus_from_url(url: str) -> SimBus:
    parts = urllib.parse.urlsplit(url)
    if parts.scheme.lower() != "sim":
        raise OptionError(f"expected a sim:// URL, got {url!r}")
    query = urllib.parse.parse_qs(parts.query, keep_blank_values=True)
    unknown = set(query) - _KNOWN
    if unknown:
        raise OptionError(
            f"sim:// URL: unknown parameter(s) {', '.join(sorted(unknown))}; known: {', '.join(sorted(_KNOWN))}"
        )

    def one(name: str, default: str) -> str:
        return query.get(name, [default])[-1]

    def number(name: str, default: str, kind: type[int] | type[float]) -> Any:
        text = one(name, default)
        try:
            if not text.isascii():  # int()/float() read Arabic-Indic and fullwidth digits; the CLI does not
                raise ValueError
            return kind(text)
        except ValueError:
            what = "a whole number" if kind is int else "a number"
            raise OptionError(f"sim:// URL: {name}={text!r} is not {what} (ASCII digits)") from None

    faults: dict[str, Any] = {k: number(k, "0" if k != "delay_rate" else "1", float) for k in _FLOAT_FAULTS}
    seed = number("seed", "0", int)
    eeprom_ms = number("eeprom_ms", "50", float)
    baud = number("baud", "9600", int)
    faults["echo"] = parse_bool(one("echo", "0"), "echo")
    check_baud(baud)
    if not (math.isfinite(eeprom_ms) and 0 <= eeprom_ms <= 10_000):
        raise OptionError(f"sim:// URL: eeprom_ms={eeprom_ms}: use a number of milliseconds, 0..10000")
    speed_zero = query["speed_zero"][-1] if "speed_zero" in query else None
    if speed_zero is not None and speed_zero not in SPEED_ZERO_CHOICES:
        raise OptionError(f"sim:// URL: speed_zero={speed_zero!r}: use one of {', '.join(SPEED_ZERO_CHOICES)}")
    product = one("product", "mc")
    ids = parse_ids(one("ids", "" if "motor" in query else "0"))
    bus = SimBus(
        wire_timing=parse_bool(one("wire_timing", "0"), "wire_timing"),
        faults=FaultConfig(**faults),
        state_dir=query["state"][-1] if "state" in query else None,
        seed=seed,
        eeprom_time=eeprom_ms / 1000,
        speed_zero=speed_zero,
    )
    try:
        for i in ids:
            bus.add_controller(i, baud, product)
        for spec in query.get("motor", []):
            i, rate, own = parse_motor(spec)
            bus.add_controller(i, rate, own or product)
        try:  # plant=ID:KEY=VALUE,... (repeatable), as nurimc sim --plant
            apply_plants(bus.controllers, query.get("plant", []))
        except PlantError as error:
            raise OptionError(f"sim:// URL: {str(error).replace('--plant ', 'plant=', 1)}") from None
    except BaseException:
        bus.close()
        raise
    return bus


class Serial(SimSerial):
    """The class pyserial's serial_for_url instantiates for sim:// URLs."""

    def open(self) -> None:
        if self.port is None:
            raise serial.SerialException("port must be configured before it can be used")
        if self.bus is None:
            try:
                self.bus = bus_from_url(str(self.port))
            except StateError:
                raise  # a state directory that cannot be used: says so itself (a usage error)
            except ValueError as exc:
                raise serial.SerialException(str(exc)) from exc
            self._own_bus = True
        super().open()
