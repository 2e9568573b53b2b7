"""Serve the bus over TCP: raw bytes (pyserial's socket:// URL) or RFC 2217 (rfc2217://).

Raw TCP carries no baud rate: a raw client talks at the rate the server was given. A client
that starts with a Telnet negotiation speaks RFC 2217 (sim/rfc2217.py) and sets its own rate
with SET-BAUDRATE, as a pseudo-terminal's host does with termios. Told apart per client by its
first bytes.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import selectors
import socket
import threading

from .core import HostLink, WireModel
from .rfc2217 import Rfc2217Session, detect, escape

log = logging.getLogger("nurimc.sim")

#: descriptors at or above this go to epoll/kqueue instead of select() (FD_SETSIZE is 1,024)
SELECT_LIMIT = 1000
#: clients served at once; one more is accepted and closed at once (with a log line)
MAX_CLIENTS = 1024
#: bytes waiting for a client that does not read; past this it is dropped (the others never wait for it)
MAX_PENDING = 64 * 1024
#: the kernel's send buffer per client (fixed: a client that does not read is noticed within ~MAX_PENDING + this)
SEND_BUFFER = 64 * 1024


class _TcpClient:
    __slots__ = ("head", "link", "peer", "pending", "raw", "session")

    def __init__(self, link: HostLink, peer: str) -> None:
        self.link = link
        self.pending = bytearray()
        self.peer = peer
        self.head = bytearray()  # first bytes, held until they tell raw from RFC 2217
        self.raw = False  # a raw client (socket://)
        self.session: Rfc2217Session | None = None  # an RFC 2217 client (rfc2217://)


class TcpServer:
    """The bus on a TCP port: `selectors` (epoll/kqueue: no FD_SETSIZE limit), non-blocking
    client sockets each with a bounded output buffer, a client cap, and a loop that logs and
    goes on after an error instead of ending (docs/simulator.md, "TCP server")."""

    def __init__(
        self,
        bus: WireModel,
        host: str,
        port: int,
        baud: int,
        monitor: bool = False,
        max_clients: int = MAX_CLIENTS,
        max_pending: int = MAX_PENDING,
    ) -> None:
        self.bus = bus
        self.baud = baud
        self.monitor = monitor
        self.max_clients = max_clients
        self.max_pending = max_pending
        self.listener = socket.create_server((host, port), backlog=128)
        self.listener.setblocking(False)
        self.address: tuple[str, int] = self.listener.getsockname()[:2]
        self.clients: dict[socket.socket, _TcpClient] = {}
        self.refused = 0  # connections closed at the cap
        self.dropped = 0  # clients dropped for not reading
        self.errors = 0  # errors the loop logged and survived
        self._wake_r, self._wake_w = os.pipe()
        for fd in (self._wake_r, self._wake_w):
            os.set_blocking(fd, False)
        self._selector = selectors.DefaultSelector()
        self._selector.register(self.listener, selectors.EVENT_READ, "listen")
        self._selector.register(self._wake_r, selectors.EVENT_READ, "wake")
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="nurimc-sim-tcp", daemon=True)

    def start(self) -> TcpServer:
        self._thread.start()
        return self

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                self._turn()
            except Exception:  # never end silently: say what happened and go on serving
                self.errors += 1
                log.exception("simulator TCP server: error in its loop (serving on)")

    def _ready(self, timeout: float | None) -> list[tuple[selectors.SelectorKey, int]]:
        """What is ready. select() while every descriptor is below its FD_SETSIZE: it waits to
        the microsecond, and the wire's timing needs that (epoll rounds a wait up to whole
        milliseconds: +1 ms on every answer at 115,200 bps). Past it, epoll/kqueue."""
        keys = {key.fd: key for key in self._selector.get_map().values()}
        if max(keys, default=0) >= SELECT_LIMIT:
            return self._selector.select(timeout)
        readers = list(keys)
        writers = [fd for fd, key in keys.items() if key.events & selectors.EVENT_WRITE]
        readable, writable, _ = select.select(readers, writers, [], timeout)
        ready: dict[int, int] = {}
        for fd in readable:
            ready[fd] = ready.get(fd, 0) | selectors.EVENT_READ
        for fd in writable:
            ready[fd] = ready.get(fd, 0) | selectors.EVENT_WRITE
        return [(keys[fd], mask) for fd, mask in ready.items()]

    def _turn(self) -> None:
        for key, events in self._ready(self.bus.wait_hint()):
            if key.data == "wake":
                with contextlib.suppress(OSError):
                    while os.read(self._wake_r, 4096):
                        pass
            elif key.data == "listen":
                self._accept()
            else:
                sock = key.fileobj
                assert isinstance(sock, socket.socket)
                if events & selectors.EVENT_READ:
                    self._read(sock)
                if events & selectors.EVENT_WRITE and sock in self.clients:
                    self._flush(sock)
        for sock, client in list(self.clients.items()):
            out = client.link.take()
            if out:
                client.pending += escape(out) if client.session is not None else out
                self._flush(sock)

    def _accept(self) -> None:
        for _ in range(64):  # a burst of connections, a bounded turn
            try:
                sock, peer = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as error:  # EMFILE and the like: said once per burst, retried next turn
                log.warning("simulator TCP server: cannot accept (%s)", error.strerror or error)
                return
            if len(self.clients) >= self.max_clients:
                self.refused += 1
                if self.refused == 1 or self.refused % 100 == 0:
                    log.warning("simulator TCP server: %d clients already; connection refused", len(self.clients))
                sock.close()
                continue
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)  # no autotuning to megabytes
            link = self.bus.open_link(self.baud, monitor=self.monitor)
            link.wake = self._wake
            where = f"{peer[0]}:{peer[1]}"
            self.clients[sock] = _TcpClient(link, where)
            self._selector.register(sock, selectors.EVENT_READ, "client")
            log.info("tcp client %s connected", where)

    def _read(self, sock: socket.socket) -> None:
        try:
            data = sock.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(sock)
            return
        client = self.clients[sock]
        if client.session is None and not client.raw:
            client.head += data
            telnet = detect(bytes(client.head[:2]))
            if telnet is None:
                return  # one 0xFF so far: the next byte tells
            data = bytes(client.head)
            client.head.clear()
            if telnet:
                client.session = self._session(client)
                log.info("tcp client %s speaks RFC 2217", client.peer)
            else:
                client.raw = True
        if client.session is None:
            client.link.write(data)
            return
        client.session.feed(data)
        if client.pending:
            self._flush(sock)

    def _session(self, client: _TcpClient) -> Rfc2217Session:
        link = client.link

        def set_baud(rate: int) -> None:
            with link.bus.lock:
                link.baud = rate
            log.info("tcp client %s: %d bps", client.peer, rate)

        def purge() -> None:
            link.take()  # what the bus sent it and it was not sent yet

        return Rfc2217Session(
            get_baud=lambda: link.baud,
            set_baud=set_baud,
            write=link.write,
            reply=client.pending.extend,
            purge=purge,
        )

    def _flush(self, sock: socket.socket) -> None:
        client = self.clients[sock]
        held = client.session is not None and client.session.suspended  # FLOWCONTROL-SUSPEND
        if client.pending and not held:
            try:
                sent = sock.send(client.pending)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self._drop(sock)
                return
            del client.pending[:sent]
        if len(client.pending) > self.max_pending:
            self.dropped += 1
            log.warning("tcp client %s does not read (%d bytes waiting): dropped", client.peer, len(client.pending))
            self._drop(sock)
            return
        want = selectors.EVENT_READ | (selectors.EVENT_WRITE if client.pending else 0)
        if self._selector.get_key(sock).events != want:
            self._selector.modify(sock, want, "client")

    def _drop(self, sock: socket.socket) -> None:
        client = self.clients.pop(sock, None)
        if client is not None:
            client.link.close()
        with contextlib.suppress(KeyError, ValueError, OSError):
            self._selector.unregister(sock)
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
        with contextlib.suppress(OSError):
            self.listener.close()
        self._selector.close()
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
