"""Typed access to the host rules of spec/host.json (timing, EEPROM busy windows, profiles)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ._host import HOST
from ._tables import SPECS

_TIMING: dict[str, Any] = HOST["timing"]
BITS_PER_BYTE: int = _TIMING["bits_per_byte"]
ADAPTER_LATENCY: float = _TIMING["adapter_latency_s"]
USB_ADAPTER_LATENCY: float = _TIMING["usb_adapter_latency_s"]
TIMING_MARGIN: float = _TIMING["margin_s"]
MAX_RESPONSE_TIME: float = _TIMING["max_response_time_s"]
RETRIES: int = _TIMING["retries"]
RETRY_PAUSE: float = _TIMING["retry_pause_s"]

#: names of the commands that start an EEPROM write (the controller is busy afterwards)
EEPROM_WRITES: frozenset[str] = frozenset(HOST["eeprom"]["writes"])
#: the same, as mode bytes
EEPROM_WRITE_MODES: frozenset[int] = frozenset(SPECS[name].mode for name in EEPROM_WRITES)
BUSY_POLL_INTERVAL: float = HOST["eeprom"]["poll_interval_s"]

#: the one emergency stop (docs/service.md): seconds control off is read back, and between rounds
STOP_VERIFY: float = HOST["stop"]["verify_s"]
STOP_RECHECK: float = HOST["stop"]["recheck_s"]

LIMITS: dict[str, float] = {k: v for k, v in HOST["limits"].items() if k != "source"}

#: the order discovery searches the rates in, most likely first (a decision: docs/protocol.md)
DISCOVERY_RATE_ORDER: tuple[int, ...] = tuple(HOST["discovery"]["rate_order"])


@dataclass(frozen=True, slots=True)
class Profile:
    """How one product behaves beyond the wire format."""

    key: str
    busy_window: float  # seconds an EEPROM write may keep the controller deaf
    speed_zero: str  # "ignore" or "stop": what a motion frame with speed 0 does
    factory_defaults: dict[str, int]


PROFILES: dict[str, Profile] = {
    key: Profile(key, p["busy_window_s"], p["speed_zero"], dict(p["factory_defaults"]))
    for key, p in HOST["profiles"].items()
}


def writes_eeprom(mode: int) -> bool:
    """Does a command with this mode start an EEPROM write?"""
    return mode in EEPROM_WRITE_MODES


#: how late an answer may be, beyond its deadline, and still be told apart (docs/protocol.md, Stale answers)
LATE_ANSWER: float = _TIMING["late_answer_s"]


def busy_window(product: str) -> float:
    """The EEPROM busy window of a product profile (profile `mc` for an unknown product)."""
    return PROFILES.get(product, PROFILES["mc"]).busy_window
