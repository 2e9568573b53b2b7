"""`SimBus`: the bus (core.py) plus the ways a host reaches it: an in-process port, a
pseudo-terminal, TCP, and monitor endpoints that hear both directions.

The endpoint modules take a bus and import only core.py, so nothing here is circular.
"""

from __future__ import annotations

from .core import HostLink, WireModel, describe
from .port import SimSerial
from .pty_server import PtyEndpoint, PtyServer
from .tcp_server import MAX_CLIENTS, TcpServer


class SimBus(WireModel):
    """Simulated controllers on one RS485 bus, with endpoints for hosts (see WireModel)."""

    def open_serial(self, baudrate: int = 9600, timeout: float | None = 0.1, monitor: bool = False) -> SimSerial:
        """An in-process, pyserial-compatible port on this bus (a monitor hears both directions)."""
        return SimSerial.on_bus(self, baudrate=baudrate, timeout=timeout, monitor=monitor)

    def serve_pty(self, link: str | None = None, monitor: bool = False) -> PtyEndpoint:
        """Serve a pseudo-terminal (and a symlink to it); returns its path, with .stop().
        A monitor pty hears every byte on the bus in both directions."""
        return PtyServer(self, link, monitor=monitor).start()

    def serve_monitor(self, link: str | None = None) -> PtyEndpoint:
        """A pseudo-terminal that hears both directions, as a second adapter on the line would."""
        return self.serve_pty(link, monitor=True)

    def serve_tcp(
        self,
        port: int = 0,
        host: str = "127.0.0.1",
        baud: int | None = None,
        monitor: bool = False,
        max_clients: int = MAX_CLIENTS,
    ) -> TcpServer:
        """Serve raw TCP (pyserial socket://); the host's rate is `baud` (default: the first controller's).
        With `monitor`, every client hears both directions."""
        if baud is None:
            baud = self.controllers[0].baud if self.controllers else 9600
        return TcpServer(self, host, port, baud, monitor=monitor, max_clients=max_clients).start()


__all__ = ["HostLink", "SimBus", "describe"]
