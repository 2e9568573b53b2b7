"""The bus service: one bus, many programs (docs/service.md)."""

from ..procedures.stop import StopResult, emergency_stop
from .core import (
    COMMAND,
    ESTOP,
    READ,
    BusService,
    Cancelled,
    ClientInfo,
    Interrupted,
    QueueFull,
    Sample,
    ServiceClosed,
    Subscription,
)

__all__ = [
    "COMMAND",
    "ESTOP",
    "READ",
    "BusService",
    "Cancelled",
    "ClientInfo",
    "Interrupted",
    "QueueFull",
    "Sample",
    "ServiceClosed",
    "StopResult",
    "Subscription",
    "emergency_stop",
]
