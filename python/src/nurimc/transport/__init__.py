"""Byte transports: how frames reach the bus. `open_transport(url)` picks one by URL."""

from .base import Transport
from .serial_transport import SerialTransport, open_transport

__all__ = ["SerialTransport", "Transport", "open_transport"]
