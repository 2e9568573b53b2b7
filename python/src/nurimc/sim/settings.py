"""A controller's non-volatile settings, with the document's factory defaults."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import Any

from ..protocol import BAUD_RATES, DEVICE_DEFAULTS, PRODUCTS

PRODUCT_NAMES = tuple(PRODUCTS)
ADDRESS_FIELDS = frozenset({"id", "baud_index"})


def check_product(product: str) -> str:
    if product not in PRODUCTS:
        raise ValueError(f"unknown product {product!r}; use one of: {', '.join(PRODUCTS)}")
    return product


@dataclass
class Settings:
    """Everything a controller keeps in EEPROM (wire integers, as the protocol carries them)."""

    id: int
    baud_index: int
    response_time: int
    rated_speed: int
    resolution: int
    ratio: int
    control: int  # 0 on, 1 off
    position_mode: int  # 0 absolute, 1 relative
    direction: int  # 0 CCW, 1 CW
    position_kp: int
    position_ki: int
    position_kd: int
    position_rated_current: int
    speed_kp: int
    speed_ki: int
    speed_kd: int
    speed_rated_current: int

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        if name in ADDRESS_FIELDS:
            hook = self.__dict__.get("address_hook")
            if hook is not None:
                hook()  # the bus re-indexes its controllers by rate and ID, however the change came

    def on_address_change(self, hook: Callable[[], None]) -> None:
        """Call `hook` whenever the ID or the rate changes (not a field: never stored)."""
        object.__setattr__(self, "address_hook", hook)

    @classmethod
    def factory(cls, product: str) -> Settings:
        """The document's defaults plus the product's (assumed) gains and rated current."""
        gains = dict(PRODUCTS[check_product(product)].defaults)
        return cls(
            **DEVICE_DEFAULTS,
            position_kp=gains["position_kp"],
            position_ki=gains["position_ki"],
            position_kd=gains["position_kd"],
            position_rated_current=gains["rated_current"],
            speed_kp=gains["speed_kp"],
            speed_ki=gains["speed_ki"],
            speed_kd=gains["speed_kd"],
            speed_rated_current=gains["rated_current"],
        )

    @property
    def baud(self) -> int:
        return BAUD_RATES[self.baud_index]

    def to_dict(self) -> dict[str, int]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], product: str) -> Settings:
        """Settings from a state file; missing or invalid entries fall back to the factory value."""
        settings = cls.factory(product)
        for f in fields(cls):
            value = data.get(f.name)
            if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 0xFFFF:
                setattr(settings, f.name, value)
        if not 0 <= settings.baud_index < len(BAUD_RATES):
            settings.baud_index = DEVICE_DEFAULTS["baud_index"]
        if settings.id > 0xFE:
            settings.id = DEVICE_DEFAULTS["id"]
        return settings
