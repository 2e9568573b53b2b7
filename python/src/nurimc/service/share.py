"""Sharing a bus between programs on this machine (docs/service.md, "Sharing").

The program that holds a port serves its BusService on a Unix domain socket named after the
port, in a directory only this user can enter (`$XDG_RUNTIME_DIR/nurimc/`, else
`/tmp/nurimc-$UID/`, mode 0700; the socket 0600). A lock file beside it (flock) makes the
holder unique: a second holder cannot start, and a socket whose holder is gone is stale,
removed and replaced, never attached to.

Messages are JSON objects, each preceded by its length (4 bytes, big-endian), at most
MAX_MESSAGE bytes. The client says hello first (program, PID, nurimc version, protocol
version; a different version is refused with a clear message), then sends requests
(`{"id": n, "op": ...}`), each answered (`{"id": n, "ok": true, "result": ...}` or
`{"id": n, "ok": false, "error": "..."}`). The holder also pushes `{"event": {...}}`
(an emergency stop, a motor that stops answering, the holder ending) and `{"sample": {...}}`
for subscriptions.

Ops: `estop`, `clients`, `known`, `subscribe` / `unsubscribe`, and the bus lease: `lease`
(the holder's queue grants the bus to this client for one procedure: `write`, `read`,
`discard`, `baud` then `release`), which is how an attached program's procedures (every CLI
command) run unchanged (`AttachedBus`). An emergency stop from anyone ends a lease at once.

A client that sends garbage, too much, or goes away mid-request is dropped; its outgoing
queue is bounded (a client that does not read is dropped, never waited for); the holder and
the other clients go on.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import json
import os
import queue
import socket
import stat
import struct
import sys
import threading
import time
import urllib.parse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..drivers.sync import Bus
from ..errors import NurimcError, PortError, PortLost
from ..protocol import BROADCAST_ID, Command, SetControl, decode
from ..version import __version__
from .core import ESTOP, BusService, ClientInfo, Sample, Subscription

PROTOCOL = 1
MAX_MESSAGE = 1 << 20  # bytes of one message, at most
OUT_QUEUE = 1000  # messages waiting for a client that does not read; past it the client is dropped
LEASE_IDLE = 2.0  # s a lease may go without an op before the holder takes the bus back
LEASE_WAIT = 30.0  # s an attached program waits for the bus (the queue) before giving up
SUN_PATH_MAX = 100  # bytes of a Unix socket's path we use, at most (the system allows 107)
HELLO_WAIT = 5.0  # s a new connection has to say hello


class ShareError(NurimcError):
    """Attaching to (or talking to) the holder of a port failed."""


class HolderGone(PortError):
    """The program holding the port ended (or closed the connection)."""


# -- where -------------------------------------------------------------------------------------
def runtime_dir() -> Path:
    """The directory of the sockets: private to this user (created 0700; refused if not ours)."""
    base = os.environ.get("XDG_RUNTIME_DIR")
    path = Path(base) / "nurimc" if base and Path(base).is_dir() else Path(f"/tmp/nurimc-{os.getuid()}")
    path.mkdir(mode=0o700, exist_ok=True)
    info = path.lstat()
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() or info.st_mode & 0o077:
        raise ShareError(
            f"{path} is not a private directory of this user (owner {info.st_uid}, mode {oct(info.st_mode & 0o777)}); "
            "remove it, or set XDG_RUNTIME_DIR to a directory of yours"
        )
    return path


def socket_path(port: str) -> Path:
    """The socket of a port: its path or URL escaped (hashed when too long for a socket name)."""
    folder = runtime_dir()
    if "://" not in port and os.path.exists(port):  # /dev/ttyUSB0 and a symlink to it are one port
        port = os.path.realpath(port)
    name = urllib.parse.quote(port, safe="")
    digest = hashlib.sha256(port.encode()).hexdigest()
    if len(name) > 60:
        name = name[:40] + "-" + digest[:16]
    if len(os.fsencode(folder / f"{name}.sock")) > SUN_PATH_MAX:  # a socket's path is short (108 bytes)
        name = digest[:24]
    path = folder / f"{name}.sock"
    if len(os.fsencode(path)) > SUN_PATH_MAX:
        raise ShareError(f"{folder} is too long a path for a socket; set XDG_RUNTIME_DIR to a shorter directory")
    return path


#: port URL schemes that are a bus of this process alone (an in-process simulator, a loopback):
#: two programs opening the same URL get two buses, so they are never shared or attached to
PRIVATE_SCHEMES = ("sim://", "loop://")


def shareable(port: str) -> bool:
    """Is this port one bus for every program on the machine (a device, a network port)?"""
    return not port.lower().startswith(PRIVATE_SCHEMES)


# -- messages ----------------------------------------------------------------------------------
def send_message(sock: socket.socket, message: dict[str, Any]) -> None:
    data = json.dumps(message, separators=(",", ":"), default=str).encode()
    sock.sendall(struct.pack(">I", len(data)) + data)


def _recv_exact(sock: socket.socket, n: int) -> bytes:
    chunks = []
    while n:
        chunk = sock.recv(n)
        if not chunk:
            raise ConnectionResetError("the other side closed the connection")
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def recv_message(sock: socket.socket) -> dict[str, Any]:
    (size,) = struct.unpack(">I", _recv_exact(sock, 4))
    if size > MAX_MESSAGE:
        raise ValueError(f"a message of {size} bytes (at most {MAX_MESSAGE})")
    message = json.loads(_recv_exact(sock, size))
    if not isinstance(message, dict):
        raise ValueError("a message that is not a JSON object")
    return message


# -- the holder ----------------------------------------------------------------------------------
class _Lease:
    """The bus granted to one client for one procedure (ends on release, idleness or a stop)."""

    def __init__(self, rate: int) -> None:
        self.rate = rate
        self.granted = threading.Event()
        self.ended = threading.Event()
        self.lock = threading.Lock()  # held while an op uses the port
        self.last_op = time.monotonic()


class _AttachedClient:
    def __init__(self, server: ShareServer, sock: socket.socket) -> None:
        self.server = server
        self.sock = sock
        self.out: queue.Queue[dict[str, Any] | None] = queue.Queue(OUT_QUEUE)
        self.info: ClientInfo | None = None
        self.subs: dict[int, Subscription] = {}
        self.lease: _Lease | None = None
        self.closed = threading.Event()
        self._writer = threading.Thread(target=self._write_loop, daemon=True, name="nurimc-share-out")

    # outgoing: one writer thread per client; a full queue drops the client (it does not read)
    def push(self, message: dict[str, Any]) -> None:
        if self.closed.is_set():
            return
        try:
            self.out.put_nowait(message)
        except queue.Full:
            self.close(f"dropped: {OUT_QUEUE} messages waited for it to read")

    def _write_loop(self) -> None:
        while True:
            message = self.out.get()
            if message is None:
                break
            try:
                send_message(self.sock, message)
            except OSError:
                break
        with contextlib.suppress(OSError):  # what was queued went out first (a refusal's reason)
            self.sock.shutdown(socket.SHUT_RDWR)
        self.close()

    def close(self, why: str | None = None) -> None:
        if self.closed.is_set():
            return
        self.closed.set()
        if why and self.info is not None:
            self.server.say(f"client {self.info.program} (pid {self.info.pid}) {why}")
        self._end_lease()
        try:
            self.out.put_nowait(None)  # the writer sends what is queued, then closes
        except queue.Full:  # it does not read: cut it off now
            with contextlib.suppress(OSError):
                self.sock.shutdown(socket.SHUT_RDWR)
        self.server._gone(self)

    def _end_lease(self) -> None:
        lease, self.lease = self.lease, None
        if lease is not None:
            lease.ended.set()

    # incoming: this thread reads and answers in order
    def serve(self) -> None:
        self._writer.start()
        try:
            self.sock.settimeout(HELLO_WAIT)
            hello = recv_message(self.sock)
            self.sock.settimeout(None)
            if not self._hello(hello):
                return
            while not self.closed.is_set():
                request = recv_message(self.sock)
                self._answer(request)
        except (OSError, ValueError, struct.error, UnicodeDecodeError) as error:
            if not self.closed.is_set() and not isinstance(error, ConnectionResetError):
                self.push({"event": {"type": "error", "message": f"bad message: {error}; connection closed"}})
        finally:
            self.close()

    def _hello(self, hello: dict[str, Any]) -> bool:
        if hello.get("op") != "hello":
            self.push({"ok": False, "error": "say hello first (op: hello)"})
            return False
        version, proto = hello.get("version"), hello.get("protocol")
        if version != __version__ or proto != PROTOCOL:
            self.push(
                {
                    "ok": False,
                    "error": f"the program holding {self.server.port} is nurimc {__version__} (protocol {PROTOCOL}), "
                    f"this one is nurimc {version} (protocol {proto}): use the same version, or close the holder",
                }
            )
            return False
        program, pid = str(hello.get("program", "?"))[:80], hello.get("pid")
        self.info = self.server.service.add_client(program, pid if isinstance(pid, int) else 0)
        bus = self.server.service.bus
        self.push(
            {
                "ok": True,
                "version": __version__,
                "protocol": PROTOCOL,
                "port": self.server.port,
                "baudrate": bus.baudrate,
            }
        )
        return True

    def _answer(self, request: dict[str, Any]) -> None:
        rid = request.get("id")
        try:
            result = self._do(str(request.get("op")), request)
        except (NurimcError, ValueError, KeyError, TypeError) as error:
            self.push({"id": rid, "ok": False, "error": str(error), "kind": type(error).__name__})
        else:
            self.push({"id": rid, "ok": True, "result": result})

    def _do(self, op: str, r: dict[str, Any]) -> Any:
        service = self.server.service
        assert self.info is not None
        if op in ("write", "read", "discard", "baud", "release"):
            return self._leased(op, r)
        if op == "lease":
            return self._take_lease(int(r["rate"]))
        self.info.requests += 1
        if op == "estop":
            return service.emergency_stop(client=self.info).as_dict()
        if op == "clients":
            return service.client_list()
        if op == "known":
            return {str(k): v for k, v in service.known.items()}
        if op == "subscribe":
            motors = [int(m) for m in r["motors"]]
            key = len(self.subs) + 1

            def deliver(sample: Sample, key: int = key) -> None:
                self.push({"sample": _sample_dict(sample), "sub": key})

            self.subs[key] = service.subscribe(
                motors, float(r["rate"]), deliver, r.get("signals", ("state",)), self.info
            )
            return {"sub": key}
        if op == "unsubscribe":
            sub = self.subs.pop(int(r["sub"]), None)
            if sub is not None:
                sub.cancel()
            return {}
        raise ValueError(f"unknown op {op!r}")

    def _take_lease(self, rate: int) -> dict[str, Any]:
        if self.lease is not None:
            raise ValueError("a lease is already held by this client")
        lease = self.lease = _Lease(rate)
        service = self.server.service
        if self.info is not None:
            self.info.requests += 1

        def hold(bus: Bus) -> None:
            with bus._lock:  # also excludes the holder program's own direct use of its Bus
                saved = bus.transport.baudrate
                if rate != saved:
                    bus.transport.baudrate = rate
                bus.transport.discard_input()
                lease.granted.set()
                try:
                    while not lease.ended.is_set() and not self.closed.is_set():
                        if service._stop_asked.is_set() or time.monotonic() - lease.last_op > LEASE_IDLE:
                            break
                        lease.ended.wait(0.005)
                finally:
                    with lease.lock:
                        lease.ended.set()
                        if bus.transport.baudrate != saved:
                            bus.transport.baudrate = saved
                        with contextlib.suppress(NurimcError, OSError):
                            bus.transport.discard_input()

        future = service.submit(hold, client=self.info)
        while not lease.granted.wait(0.05):
            if future.done():
                self.lease = None
                future.result()  # raises the reason (cancelled by a stop, the service ended)
                raise ShareError("the bus was not granted")
        lease.last_op = time.monotonic()
        return {"granted": True}

    def _leased(self, op: str, r: dict[str, Any]) -> Any:
        lease = self.lease
        if op == "release":
            self._end_lease()
            return {}
        if lease is None or lease.ended.is_set():
            self.lease = None
            raise ShareError("the bus was taken back (an emergency stop, or the lease sat idle); start again")
        transport = self.server.service.bus.transport
        with lease.lock:
            if lease.ended.is_set():
                raise ShareError("the bus was taken back (an emergency stop); start again")
            lease.last_op = time.monotonic()
            try:
                if op == "write":
                    data = bytes.fromhex(str(r["data"]))
                    self.server.commanded(data)
                    transport.write(data)
                    return {}
                if op == "read":
                    timeout = min(max(float(r["seconds"]), 0.0), 1.0)
                    return transport.read(min(int(r["max"]), 4096), timeout).hex()
                if op == "discard":
                    return transport.discard_input().hex()
                rate = int(r["rate"])
                transport.baudrate = rate
                return {}
            finally:
                lease.last_op = time.monotonic()


def _sample_dict(sample: Sample) -> dict[str, Any]:
    state = sample.state
    return {
        "id": sample.id,
        "t": sample.t,
        "error": sample.error,
        "silent_since": sample.silent_since,
        "state": None
        if state is None
        else {
            "position": state.position,
            "device_position": state.device_position,
            "speed": state.speed,
            "current": state.current,
            "direction": state.direction,
        },
    }


class ShareServer:
    """Serves a BusService on the port's socket (see the module's text). `start()` takes the
    lock (ShareError if another holder has it) and listens; `close()` tells every client."""

    def __init__(self, service: BusService, port: str, say: Callable[[str], None] | None = None) -> None:
        self.service = service
        self.port = port
        self.say = say or (lambda text: print(text, file=sys.stderr, flush=True))
        self.path = socket_path(port)
        self.lock_path = self.path.with_suffix(".lock")
        self._lock_fd: int | None = None
        self._sock: socket.socket | None = None
        self._clients: set[_AttachedClient] = set()
        self._mutex = threading.Lock()
        self._thread: threading.Thread | None = None
        self._closing = False
        self._unlisten = service.listen(self._event)

    def start(self) -> ShareServer:
        fd = os.open(self.lock_path, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            os.close(fd)
            raise ShareError(f"another nurimc program already holds {self.port} (lock {self.lock_path})") from error
        self._lock_fd = fd
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()  # stale: its holder is gone (we have the lock)
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)
        try:
            sock.bind(str(self.path))
        finally:
            os.umask(old)
        os.chmod(self.path, 0o600)
        sock.listen(16)
        self._sock = sock
        self._thread = threading.Thread(target=self._accept, daemon=True, name="nurimc-share")
        self._thread.start()
        return self

    def _accept(self) -> None:
        assert self._sock is not None
        while not self._closing:
            try:
                conn, _ = self._sock.accept()
            except OSError:
                break
            client = _AttachedClient(self, conn)
            with self._mutex:
                self._clients.add(client)
            threading.Thread(target=client.serve, daemon=True, name="nurimc-share-client").start()

    def _gone(self, client: _AttachedClient) -> None:
        with self._mutex:
            self._clients.discard(client)
        for sub in client.subs.values():
            sub.cancel()
        if client.info is not None:
            self.service.remove_client(client.info)

    def _event(self, event: dict[str, Any]) -> None:
        with self._mutex:
            clients = list(self._clients)
        for client in clients:
            client.push({"event": event})

    def commanded(self, frame: bytes) -> None:
        """An attached program sent this frame: a motion or control-on command clears that motor's stop latch."""
        try:
            message = decode(frame)
        except Exception:
            return
        if not isinstance(message, Command) or message.id == BROADCAST_ID:
            return
        if isinstance(message, SetControl) and message.control:
            return  # control off is not "commanded again"
        device_id = message.id
        with self.service._cond:
            self.service.latched.discard(device_id)

    def close(self, why: str = "the holder ended") -> None:
        self._closing = True
        self._unlisten()
        with self._mutex:
            clients = list(self._clients)
        for client in clients:
            client.push({"event": {"type": "closed", "message": f"{why}: the port {self.port} is no longer served"}})
            client.close()
        if self._sock is not None:
            with contextlib.suppress(OSError):
                self._sock.close()
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        if self._lock_fd is not None:
            with contextlib.suppress(FileNotFoundError):
                self.lock_path.unlink()
            os.close(self._lock_fd)
            self._lock_fd = None


# -- attached programs -----------------------------------------------------------------------------
class Connection:
    """A client's connection to a holder: requests answered in order, events to `on_event`."""

    def __init__(self, sock: socket.socket, port: str, on_event: Callable[[dict[str, Any]], None] | None) -> None:
        self.sock = sock
        self.port = port
        self.on_event = on_event
        self.on_sample: Callable[[dict[str, Any], int], None] | None = None
        self._ids = iter(range(1, 1 << 62))
        self._answers: dict[int, queue.Queue[dict[str, Any]]] = {}
        self._lock = threading.Lock()
        self.gone: str | None = None
        self.hello: dict[str, Any] = {}
        self._reader: threading.Thread | None = None

    def start(self) -> None:
        self._reader = threading.Thread(target=self._read_loop, daemon=True, name="nurimc-attached")
        self._reader.start()

    def _read_loop(self) -> None:
        try:
            while True:
                message = recv_message(self.sock)
                if "event" in message:
                    event = message["event"]
                    if event.get("type") == "closed":
                        self.gone = str(event.get("message"))
                    if self.on_event is not None:
                        self.on_event(event)
                elif "sample" in message:
                    if self.on_sample is not None:
                        self.on_sample(message["sample"], int(message.get("sub", 0)))
                else:
                    with self._lock:
                        waiting = self._answers.pop(int(message.get("id", -1)), None)
                    if waiting is not None:
                        waiting.put(message)
        except (OSError, ValueError, struct.error):
            pass
        if self.gone is None:
            self.gone = f"the nurimc program holding {self.port} has ended"
            if self.on_event is not None:
                self.on_event({"type": "closed", "message": self.gone})
        with self._lock:
            waiting_all, self._answers = list(self._answers.values()), {}
        for waiting in waiting_all:
            waiting.put({"ok": False, "error": self.gone, "kind": "HolderGone"})

    def call(self, op: str, timeout: float | None = None, **fields: Any) -> Any:
        if self.gone is not None:
            raise HolderGone(f"{self.gone}; run the command again (it opens the port itself now)")
        rid = next(self._ids)
        answer: queue.Queue[dict[str, Any]] = queue.Queue(1)
        with self._lock:
            self._answers[rid] = answer
        try:
            send_message(self.sock, {"id": rid, "op": op, **fields})
            reply = answer.get(timeout=timeout)
        except OSError as error:  # the connection is closed: the holder ended (its goodbye may not have come yet)
            raise HolderGone(
                f"the nurimc program holding {self.port} has ended ({error}); run the command again (it opens "
                "the port itself now)"
            ) from error
        except queue.Empty as error:
            raise HolderGone(
                f"the nurimc program holding {self.port} does not answer within {timeout:g} s: see "
                f"`nurimc --port {self.port} clients`, or stop it and run the command again"
            ) from error
        if not reply.get("ok"):
            text = str(reply.get("error"))
            if reply.get("kind") == "HolderGone":
                raise HolderGone(f"{text}; run the command again (it opens the port itself now)")
            if reply.get("kind") == "PortLost":
                raise PortLost(text)
            raise ShareError(text)
        return reply.get("result")

    def close(self) -> None:
        """This program is done with the holder (nothing to report)."""
        if self.gone is None:
            self.gone = "this program closed its connection to the holder"
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()


def connect(port: str, program: str, on_event: Callable[[dict[str, Any]], None] | None = None) -> Connection | None:
    """Attach to the holder of `port`; None when no live holder serves it (a stale socket is removed)."""
    try:
        path = socket_path(port)
    except ShareError:
        return None
    if not path.exists():
        return None
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        sock.connect(str(path))
    except OSError as error:
        sock.close()
        if error.errno in (errno.ECONNREFUSED, errno.ENOENT):
            _remove_stale(path)
            return None
        raise ShareError(f"cannot attach to the holder of {port} ({path}): {error.strerror or error}") from error
    try:
        sock.settimeout(HELLO_WAIT)
        send_message(
            sock, {"op": "hello", "program": program, "pid": os.getpid(), "version": __version__, "protocol": PROTOCOL}
        )
        hello = recv_message(sock)
        sock.settimeout(None)
    except (OSError, ValueError, struct.error) as error:
        sock.close()
        raise ShareError(f"the holder of {port} did not say hello: {error}") from error
    if not hello.get("ok"):
        sock.close()
        raise ShareError(str(hello.get("error")))
    conn = Connection(sock, port, on_event)
    conn.hello = hello
    conn.start()
    return conn


def _remove_stale(path: Path) -> None:
    """A socket nobody listens on: removed, unless a holder holds its lock (then it is starting)."""
    lock = path.with_suffix(".lock")
    try:
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o600)
    except OSError:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return
    with contextlib.suppress(FileNotFoundError):
        path.unlink()
    os.close(fd)


class RemoteTransport:
    """The holder's port as seen by an attached program, while it holds a lease."""

    def __init__(self, conn: Connection, url: str, baudrate: int) -> None:
        self.conn = conn
        self.url = url
        self.latency = 0.002
        self._baud = baudrate
        self.leased = False

    @property
    def baudrate(self) -> int:
        return self._baud

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        if self.leased:
            self.conn.call("baud", rate=rate)
        self._baud = rate

    def write(self, data: bytes) -> None:
        self.conn.call("write", data=data.hex())

    def read(self, max_bytes: int, timeout: float) -> bytes:
        return bytes.fromhex(self.conn.call("read", max=max_bytes, seconds=timeout))

    def discard_input(self) -> bytes:
        return bytes.fromhex(self.conn.call("discard")) if self.leased else b""

    def close(self) -> None:
        self.conn.close()


class AttachedBus(Bus):
    """A Bus whose port is held by another nurimc program: each procedure runs while the holder
    grants the bus (a lease through its queue), so every command works as on an own port."""

    def __init__(self, conn: Connection, port: str, baudrate: int, **options: Any) -> None:
        self.conn = conn
        self.remote = RemoteTransport(conn, port, baudrate)
        self._subs: dict[int, Callable[[dict[str, Any]], None]] = {}
        super().__init__(self.remote, **options)
        self._fast_path = False  # every request goes through run(): the holder's lease

    def run(self, procedure: Any, on_note: Callable[[Any], None] | None = None, timeout: float | None = None) -> Any:
        with self._lock:
            self.conn.call("lease", timeout=LEASE_WAIT, rate=self.remote.baudrate)
            self.remote.leased = True
            try:
                return super().run(procedure, on_note, timeout)
            finally:
                self.remote.leased = False
                with contextlib.suppress(NurimcError):
                    self.conn.call("release")

    def subscribe(self, motors: list[int], rate_hz: float, callback: Callable[[dict[str, Any]], None]) -> int:
        """Readings of `motors` from the holder's shared poll schedule (no lease, no extra reads
        when the holder reads them anyway): `callback(sample)` from the connection's thread,
        sample as {"id", "t", "state": {...} or None, "error", "silent_since"}."""
        key = int(self.conn.call("subscribe", timeout=10, motors=list(motors), rate=rate_hz)["sub"])
        self._subs[key] = callback
        self.conn.on_sample = self._sample
        return key

    def _sample(self, sample: dict[str, Any], key: int) -> None:
        callback = self._subs.get(key)
        if callback is not None:
            callback(sample)

    def emergency_stop(self) -> dict[str, Any]:
        result: dict[str, Any] = self.conn.call("estop", timeout=30)
        return result

    def clients(self) -> list[dict[str, Any]]:
        result: list[dict[str, Any]] = self.conn.call("clients", timeout=10)
        return result

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self.conn.close()
        super().close()


#: Bus options that mean something on an attached bus (the port's own options are the holder's)
ATTACHED_OPTIONS = frozenset(
    {
        "retries",
        "timing",
        "log_path",
        "tracer",
        "listeners",
        "busy_window",
        "busy_windows",
        "late_answer",
        "retry_pause",
    }
)


def open_shared(port: str, baudrate: int = 9600, program: str = "python", **options: Any) -> Bus:
    """For library users: attach to the nurimc program holding `port` (docs/service.md), else
    open the port itself (`Bus.open`, with every option). Attached, the port's own options
    (reconnect, latency, rs485) are the holder's and are ignored."""
    if shareable(port):
        conn = connect(port, program)
        if conn is not None:
            kept = {k: v for k, v in options.items() if k in ATTACHED_OPTIONS}
            return AttachedBus(conn, port, baudrate, **kept)
    return Bus.open(port, baudrate=baudrate, **options)


__all__ = [
    "ESTOP",
    "AttachedBus",
    "Connection",
    "HolderGone",
    "RemoteTransport",
    "ShareError",
    "ShareServer",
    "connect",
    "open_shared",
    "shareable",
    "socket_path",
]
