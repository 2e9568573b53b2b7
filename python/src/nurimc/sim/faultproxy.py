"""A port that can be cut and restored, in front of the simulator: the adapter that drops out.

    python -m nurimc.sim.faultproxy --upstream 127.0.0.1:PORT --link /tmp/ttyCut
    python -m nurimc.sim.faultproxy --upstream 127.0.0.1:PORT --tcp 0

It connects to a simulator's TCP port (`nurimc sim --tcp 0`) and serves the host either a
pseudo-terminal (a symlink at --link, as a /dev/serial/by-id name) or a TCP port. `cut` makes
the port fail as an unplugged USB adapter does: the pty's master is closed (the host's reads
and writes get EIO) and the link removed (reopening fails: no such file); TCP connections are
reset and the port refuses new ones. `restore` brings it back: a new pseudo-terminal (another
/dev/pts number, as a re-enumerated adapter gets another ttyUSBn) behind the same link, or the
same TCP port listening again. Bytes the simulator sends while cut are dropped and counted.

SIGUSR1 cuts, SIGUSR2 restores; `--cut-at S --cut-for S` does it on a schedule. Each change is
printed as one line with the time (s since start), for benchmarks and checks from outside.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import queue
import select
import signal
import socket
import struct
import sys
import threading
import time
import tty
from pathlib import Path


class FaultProxy:
    """Forwards bytes between a host-side port (pty or TCP) and the simulator's TCP port."""

    def __init__(self, upstream: tuple[str, int], link: str | None = None, tcp_port: int | None = None) -> None:
        if (link is None) == (tcp_port is None):
            raise ValueError("give either a link path (pty) or a TCP port")
        self.link = link
        self.upstream = socket.create_connection(upstream)
        self.upstream.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.tcp_port = tcp_port
        self.is_cut = False
        self.dropped = 0  # bytes from the simulator thrown away while cut
        self.cuts = 0
        #: every chunk the host sent, in order, with the number of cuts before it (for tests)
        self.from_host: list[tuple[int, bytes]] = []
        self._master: int | None = None
        self._slave: int | None = None
        self._listener: socket.socket | None = None
        self._clients: list[socket.socket] = []
        self._requests: queue.Queue[tuple[str, threading.Event]] = queue.Queue()
        self._wake_r, self._wake_w = os.pipe()
        self._stopping = False
        self._open()
        self._thread = threading.Thread(target=self._serve, name="nurimc-faultproxy", daemon=True)

    @property
    def url(self) -> str:
        """What the host opens."""
        if self.link is not None:
            return self.link
        return f"socket://127.0.0.1:{self.tcp_port}"

    def start(self) -> FaultProxy:
        self._thread.start()
        return self

    def cut(self) -> None:
        self._ask("cut")

    def restore(self) -> None:
        self._ask("restore")

    def stop(self) -> None:
        self._ask("stop")
        self._thread.join(timeout=5)
        self.upstream.close()
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)

    def _ask(self, what: str) -> None:
        done = threading.Event()
        self._requests.put((what, done))
        os.write(self._wake_w, b"x")
        if self._thread.is_alive():
            done.wait(5)
        else:  # not started (or finished): carry it out here
            self._carry_out(what)

    # -- the port's two lives ----------------------------------------------------------------
    def _open(self) -> None:
        if self.link is not None:
            self._master, self._slave = os.openpty()
            tty.setraw(self._slave)
            link = Path(self.link)
            link.unlink(missing_ok=True)
            link.symlink_to(os.ttyname(self._slave))
        else:
            self._listener = socket.create_server(("127.0.0.1", self.tcp_port or 0))
            self.tcp_port = self._listener.getsockname()[1]
        self.is_cut = False

    def _close(self) -> None:
        if self.link is not None:
            Path(self.link).unlink(missing_ok=True)
            for fd in (self._master, self._slave):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            self._master = self._slave = None
        else:
            for client in self._clients:
                with contextlib.suppress(OSError):  # a reset, not a polite close: as a cable pulled
                    client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                    client.close()
            self._clients = []
            if self._listener is not None:
                self._listener.close()
                self._listener = None
        self.is_cut = True

    def _carry_out(self, what: str) -> None:
        if what == "cut" and not self.is_cut:
            self.cuts += 1
            self._close()
        elif what == "restore" and self.is_cut:
            self._open()
        elif what == "stop":
            self._stopping = True
            if not self.is_cut:
                self._close()

    # -- forwarding --------------------------------------------------------------------------
    def _serve(self) -> None:
        while not self._stopping:
            watched: list[int | socket.socket] = [self._wake_r, self.upstream, *self._clients]
            if self._master is not None:
                watched.append(self._master)
            if self._listener is not None:
                watched.append(self._listener)
            try:
                readable, _, _ = select.select(watched, [], [], 1.0)
            except (OSError, ValueError):
                readable = []
            if self._wake_r in readable:
                os.read(self._wake_r, 64)
            while not self._requests.empty():
                what, done = self._requests.get()
                self._carry_out(what)
                done.set()
            if self._stopping:
                return
            if self.upstream in readable:
                self._from_sim()
            if self._master is not None and self._master in readable:
                try:
                    data = os.read(self._master, 4096)
                except OSError:  # nobody has the pty open just now
                    data = b""
                if data:
                    self._to_sim(data)
            if self._listener is not None and self._listener in readable:
                client, _ = self._listener.accept()
                client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._clients.append(client)
            for client in list(self._clients):
                if client in readable:
                    try:
                        data = client.recv(4096)
                    except OSError:
                        data = b""
                    if data:
                        self._to_sim(data)
                    else:
                        self._clients.remove(client)
                        client.close()

    def _to_sim(self, data: bytes) -> None:
        self.from_host.append((self.cuts, data))
        del self.from_host[:-10_000]
        self.upstream.sendall(data)

    def _from_sim(self) -> None:
        data = self.upstream.recv(4096)
        if not data:
            self._stopping = True
            return
        if self.is_cut:
            self.dropped += len(data)
            return
        if self._master is not None:
            with contextlib.suppress(OSError):
                os.write(self._master, data)
        for client in self._clients:
            with contextlib.suppress(OSError):
                client.sendall(data)


def _address(text: str) -> tuple[str, int]:
    host, _, port = text.rpartition(":")
    if host not in ("127.0.0.1", "localhost", "::1") or not port.isdigit():
        raise argparse.ArgumentTypeError(f"{text}: give 127.0.0.1:PORT (the simulator's --tcp port)")
    return host, int(port)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m nurimc.sim.faultproxy", description=__doc__.split("\n")[0])
    parser.add_argument("--upstream", type=_address, required=True, help="the simulator's TCP port, 127.0.0.1:PORT")
    side = parser.add_mutually_exclusive_group(required=True)
    side.add_argument("--link", help="serve a pty with a symlink at this path")
    side.add_argument("--tcp", type=int, help="serve TCP on this port of 127.0.0.1 (0: any free one)")
    parser.add_argument("--cut-at", type=float, action="append", default=[], help="cut at this many seconds")
    parser.add_argument("--cut-for", type=float, default=3.0, help="seconds each scheduled cut lasts")
    args = parser.parse_args(argv)
    try:
        proxy = FaultProxy(args.upstream, link=args.link, tcp_port=args.tcp).start()
    except OSError as error:
        print(f"faultproxy: cannot start: {error}", file=sys.stderr)
        return 1
    start = time.monotonic()

    def say(text: str) -> None:
        print(f"{time.monotonic() - start:.3f} {text}", flush=True)

    def cut(*_: object) -> None:
        proxy.cut()
        say("cut")

    def restore(*_: object) -> None:
        proxy.restore()
        say(f"restored {proxy.url}")

    signal.signal(signal.SIGUSR1, cut)
    signal.signal(signal.SIGUSR2, restore)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    say(f"ready {proxy.url}")
    try:
        for at in sorted(args.cut_at):
            if stop.wait(max(0.0, start + at - time.monotonic())):
                break
            cut()
            if stop.wait(args.cut_for):
                break
            restore()
        stop.wait()
    except KeyboardInterrupt:
        pass
    finally:
        proxy.stop()
        say(f"stopped (dropped {proxy.dropped} bytes while cut)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
