"""Byte transports: how frames reach the bus. `open_transport(url)` picks one by URL
(backends.py: the table of URL schemes; rs485.py: direction control for bare RS485 adapters)."""

from .backends import BACKENDS, register_backend
from .base import Transport
from .rs485 import RS485
from .serial_transport import SerialTransport, open_transport

__all__ = ["BACKENDS", "RS485", "SerialTransport", "Transport", "open_transport", "register_backend"]
