"""Serve the bus over TCP (raw bytes, usable with pyserial's socket:// URL).

TCP carries no baud rate, so every client talks at the rate the server was given.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import socket
import threading

from .core import HostLink, WireModel

log = logging.getLogger("nurimc.sim")


class TcpServer:
    def __init__(self, bus: WireModel, host: str, port: int, baud: int, monitor: bool = False) -> None:
        self.bus = bus
        self.baud = baud
        self.monitor = monitor
        self.listener = socket.create_server((host, port))
        self.listener.setblocking(False)
        self.address: tuple[str, int] = self.listener.getsockname()[:2]
        self.clients: dict[socket.socket, HostLink] = {}
        self._wake_r, self._wake_w = os.pipe()
        for fd in (self._wake_r, self._wake_w):
            os.set_blocking(fd, False)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="nurimc-sim-tcp", daemon=True)

    def start(self) -> TcpServer:
        self._thread.start()
        return self

    def _serve(self) -> None:
        while not self._stop.is_set():
            sockets: list[socket.socket | int] = [self.listener, self._wake_r, *self.clients]
            try:
                readable, _, _ = select.select(sockets, [], [], self.bus.wait_hint())
            except (OSError, ValueError):
                break
            if self._wake_r in readable:
                with contextlib.suppress(OSError):
                    while os.read(self._wake_r, 4096):
                        pass
            if self.listener in readable:
                self._accept()
            for sock in list(self.clients):
                if sock in readable:
                    self._read(sock)
            for sock, link in list(self.clients.items()):
                out = link.take()
                if out:
                    try:
                        sock.sendall(out)
                    except OSError:
                        self._drop(sock)

    def _accept(self) -> None:
        try:
            sock, peer = self.listener.accept()
        except OSError:
            return
        sock.setblocking(True)
        sock.settimeout(1.0)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        link = self.bus.open_link(self.baud, monitor=self.monitor)
        link.wake = self._wake
        self.clients[sock] = link
        log.info("tcp client %s:%d connected", *peer[:2])

    def _read(self, sock: socket.socket) -> None:
        try:
            data = sock.recv(4096)
        except OSError:
            data = b""
        if not data:
            self._drop(sock)
            return
        self.clients[sock].write(data)

    def _drop(self, sock: socket.socket) -> None:
        link = self.clients.pop(sock, None)
        if link is not None:
            link.close()
        with contextlib.suppress(OSError):
            sock.close()

    def _wake(self) -> None:
        if threading.current_thread() is self._thread and not self._stop.is_set():
            return  # our own loop delivered them: it writes them out before it sleeps again
        with contextlib.suppress(OSError):  # full (a wake is pending anyway) or closed
            os.write(self._wake_w, b"x")

    def stop(self) -> None:
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake()
        if self._thread.is_alive():
            self._thread.join(timeout=2)
        for sock in list(self.clients):
            self._drop(sock)
        for closable in (self.listener,):
            with contextlib.suppress(OSError):
                closable.close()
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
