"""nurimc: toolkit for Nurirobot MC and BLMC-H motor controllers (MC-RS485 V1.0.1).

from nurimc import Bus
with Bus.open("sim://?ids=1,2", baudrate=9600) as bus:
    motor = bus.motor(1)
    motor.move_to(90, rpm=60)
    print(motor.read_state())

The top level imports lazily: `import nurimc.protocol` (the sans-I/O core) needs no
third-party package; the bus client (pyserial) loads on first use of a name below.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .version import __version__ as __version__

# name -> module that defines it (relative to this package)
_LAZY = {
    "AsyncBus": ".drivers.aio",
    "AsyncGroup": ".procedures.group",
    "AsyncMotor": ".drivers.aio",
    "Bus": ".drivers.sync",
    "Group": ".procedures.group",
    "Motor": ".procedures.motor",
    "MotorState": ".procedures.motor",
    "ConfirmationRequired": ".errors",
    "ControllerBusy": ".errors",
    "CorruptedAnswer": ".errors",
    "IdInUse": ".errors",
    "InputError": ".errors",
    "NoAnswer": ".errors",
    "NurimcError": ".errors",
    "PortError": ".errors",
    "SettingNotApplied": ".errors",
    "UnexpectedAnswer": ".errors",
}

__all__ = [
    "AsyncBus",
    "AsyncGroup",
    "AsyncMotor",
    "Bus",
    "ConfirmationRequired",
    "ControllerBusy",
    "CorruptedAnswer",
    "Group",
    "IdInUse",
    "InputError",
    "Motor",
    "MotorState",
    "NoAnswer",
    "NurimcError",
    "PortError",
    "SettingNotApplied",
    "UnexpectedAnswer",
]

if TYPE_CHECKING:
    from .drivers.aio import AsyncBus, AsyncMotor
    from .drivers.sync import Bus
    from .errors import (
        ConfirmationRequired,
        ControllerBusy,
        CorruptedAnswer,
        IdInUse,
        InputError,
        NoAnswer,
        NurimcError,
        PortError,
        SettingNotApplied,
        UnexpectedAnswer,
    )
    from .procedures.group import AsyncGroup, Group
    from .procedures.motor import Motor, MotorState


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'nurimc' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])
