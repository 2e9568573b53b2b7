"""The bus service: one bus, many programs (docs/service.md)."""

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
from .stop import StopResult, emergency_stop

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
