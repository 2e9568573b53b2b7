"""nurimc: toolkit for Nurirobot MC and BLMC-H motor controllers (MC-RS485 V1.0.1).

from nurimc import Bus
with Bus.open("sim://?ids=1", baudrate=9600) as bus:
    motor = bus.motor(1)
    motor.move_to(90, rpm=60)
    print(motor.read_state())
"""

from .client.aio import AsyncBus, AsyncMotor
from .client.sync import Bus
from .errors import (
    ConfirmationRequired,
    CorruptedAnswer,
    IdInUse,
    NoAnswer,
    NurimcError,
    PortError,
    SettingNotApplied,
    UnexpectedAnswer,
)
from .group import Group
from .motor import Motor, MotorState

__version__ = "0.1.0"

__all__ = [
    "AsyncBus",
    "AsyncMotor",
    "Bus",
    "ConfirmationRequired",
    "CorruptedAnswer",
    "Group",
    "IdInUse",
    "Motor",
    "MotorState",
    "NoAnswer",
    "NurimcError",
    "PortError",
    "SettingNotApplied",
    "UnexpectedAnswer",
]
