"""A controller's non-volatile settings, with the document's factory defaults."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, fields
from typing import Any

from ..protocol import BAUD_RATES, DEVICE_DEFAULTS, PRODUCTS, Message
from ..protocol import messages as m
from ..protocol._settings import SETTINGS as SPEC_SETTINGS
from ..protocol.host import PROFILES
from ..protocol.schema import FieldSpec, MessageSpec

PRODUCT_NAMES = tuple(PRODUCTS)
ADDRESS_FIELDS = frozenset({"id", "baud_index"})

# Each setting's range is that of the field of the command that writes it: the ID and the rate
# (addresses, not in the settings map), then every writable setting of the generated spec
# (spec/settings.json), by its stored name (`speed-kp` is stored as speed_kp).
_WRITERS: dict[str, tuple[type[Message], str]] = {
    "id": (m.SetId, "new_id"),
    "baud_index": (m.SetBaud, "baud_index"),
    **{
        s["name"].replace("-", "_"): (m.MESSAGES[s["command"]], s["field"])
        for s in SPEC_SETTINGS
        if s["command"] is not None
    },
}


def _field(name: str) -> tuple[MessageSpec, FieldSpec]:
    cls, field_name = _WRITERS[name]
    spec = cls.SPEC
    return spec, next(f for f in spec.fields if f.name == field_name)


def setting_problem(name: str, value: object) -> str | None:
    """Why `value` cannot be the setting `name` (unknown, not an integer, out of range), or None."""
    if name not in _WRITERS:
        return f"{name!r} is not a setting (known: {', '.join(_WRITERS)})"
    spec, f = _field(name)
    if not isinstance(value, int) or isinstance(value, bool):
        return f"{name!r}: {value!r} is not an integer"
    if not f.min <= value <= f.max:
        return f"{name!r}: {value} is out of range; allowed {f.min}..{f.max} (as {spec.name} carries it)"
    return None


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
    def factory(cls, product: str, defaults: dict[str, int] | None = None) -> Settings:
        """The document's defaults plus the product profile's factory gains and rated current
        (spec/profiles.json, or `defaults` from a --profile file)."""
        gains = dict(PROFILES[check_product(product)].factory_defaults if defaults is None else defaults)
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
    def from_dict(cls, data: dict[str, Any], product: str, defaults: dict[str, int] | None = None) -> Settings:
        """Settings from a state file, which must hold every setting, each in its range
        (ValueError naming the field otherwise; see validate_stored)."""
        problem = stored_problem(data)
        if problem is not None:
            raise ValueError(problem)
        settings = cls.factory(product, defaults)
        for f in fields(cls):
            setattr(settings, f.name, data[f.name])
        return settings


def stored_problem(data: object) -> str | None:
    """What is wrong with a stored settings record (a missing, unknown or out-of-range field), or None."""
    if not isinstance(data, dict):
        return "'settings' is not an object"
    for f in fields(Settings):
        if f.name not in data:
            return f"field {f.name!r} is missing"
    for name, value in data.items():
        problem = setting_problem(name, value)
        if problem is not None:
            return f"field {problem}"
    return None
