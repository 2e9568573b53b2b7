"""Serve the bus on a pseudo-terminal that any serial program opens like a USB adapter."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
import select
import stat
import struct
import termios
import threading
import tty
from pathlib import Path

from .core import HostLink, WireModel

log = logging.getLogger("nurimc.sim")

TCGETS2 = 0x802C542A  # struct termios2: c_ispeed, c_ospeed are uint32 at offsets 36 and 40
TERMIOS2_SIZE = 44


def host_baud(fd: int, fallback: int) -> int:
    """The baud rate the host set on the terminal (any rate, standard or not)."""
    try:
        raw = fcntl.ioctl(fd, TCGETS2, bytes(TERMIOS2_SIZE))
        _, ospeed = struct.unpack_from("=II", raw, 36)
        return int(ospeed) or fallback
    except OSError:
        return fallback


def _drain(fd: int) -> None:
    with contextlib.suppress(OSError):
        while os.read(fd, 4096):
            pass


# the pseudo-terminals this process serves, by slave path (to tell our own from another's)
_SERVED: dict[str, PtyServer] = {}


def _live_terminal(target: str) -> bool:
    try:
        return stat.S_ISCHR(os.stat(target).st_mode)
    except OSError:
        return False


class PtyEndpoint(str):
    """The slave device path (a str, so it can be passed to serial.Serial) with .stop()."""

    server: PtyServer

    @property
    def path(self) -> str:
        return str(self)

    @property
    def link(self) -> str | None:
        return self.server.link_path

    def stop(self) -> None:
        self.server.stop()


class PtyServer:
    def __init__(self, bus: WireModel, link_path: str | None = None, monitor: bool = False) -> None:
        self.bus = bus
        self.link_path = link_path
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no line editing until the host configures it
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        default_baud = bus.controllers[0].baud if bus.controllers else 9600
        attrs = termios.tcgetattr(self.slave)
        speed = getattr(termios, f"B{default_baud}", termios.B9600)
        attrs[4] = attrs[5] = speed
        termios.tcsetattr(self.slave, termios.TCSANOW, attrs)
        self.host: HostLink = bus.open_link(host_baud(self.master, default_baud), monitor=monitor)
        self._wake_r, self._wake_w = os.pipe()
        for fd in (self._wake_r, self._wake_w):
            os.set_blocking(fd, False)
        self.host.wake = self._wake
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="nurimc-sim-pty", daemon=True)

    def start(self) -> PtyEndpoint:
        if self.link_path:
            try:
                self._make_link(Path(self.link_path))
            except BaseException:
                self.host.close()
                self._close_fds()
                raise
        _SERVED[self.path] = self
        self._thread.start()
        endpoint = PtyEndpoint(self.path)
        endpoint.server = self
        return endpoint

    def _make_link(self, link: Path) -> None:
        """Point `link` at our pty. A link to a live pseudo-terminal belongs to someone else
        (another simulator): refused. A link to a vanished one (its owner was killed: a pts
        node disappears with its master) is stale and replaced."""
        if link.is_symlink() or link.exists():
            if not link.is_symlink():
                raise FileExistsError(f"{link} exists and is not a symlink; choose another path")
            target = os.readlink(link)
            if self._owned_elsewhere(link, target):
                raise FileExistsError(
                    f"{link} points to {target}, a pseudo-terminal still in use (another simulator?); "
                    "stop that one or choose another path"
                )
            link.unlink(missing_ok=True)
        try:
            link.symlink_to(self.path)
        except FileExistsError:
            raise FileExistsError(f"{link} was just created by someone else; choose another path") from None

    def _owned_elsewhere(self, link: Path, target: str) -> bool:
        """Does `link` (pointing at `target`) belong to a live endpoint other than us? A pty
        number is reused once its owner is gone, so a link to a pty this process serves is
        stale unless that endpoint made this very link."""
        if target == self.path:
            return False
        ours = _SERVED.get(target)
        if ours is not None:
            return ours.link_path is not None and os.path.abspath(ours.link_path) == os.path.abspath(link)
        return _live_terminal(target)

    def _serve(self) -> None:
        pending = bytearray()
        while not self._stop.is_set():
            timeout = self.bus.wait_hint()
            want_write = [self.master] if pending else []
            try:
                readable, _, _ = select.select([self.master, self._wake_r], want_write, [], timeout)
            except (OSError, ValueError):
                break
            if self._wake_r in readable:
                _drain(self._wake_r)
            if self.master in readable:
                try:
                    data = os.read(self.master, 4096)
                except OSError as exc:
                    if exc.errno not in (errno.EAGAIN, errno.EIO):
                        log.warning("pty read failed: %s", exc)
                    data = b""
                if data:
                    self.host.baud = host_baud(self.master, self.host.baud)
                    self.host.write(data)
            pending += self.host.take()
            if pending:
                try:
                    written = os.write(self.master, pending)
                    del pending[:written]
                except BlockingIOError:
                    pass  # the host is not reading; keep the bytes for later
                except OSError as exc:
                    log.warning("pty write failed: %s", exc)
                    pending.clear()
                if len(pending) > 65536:  # a host that never reads loses the oldest bytes
                    del pending[:-65536]

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
        self.host.close()
        if _SERVED.get(self.path) is self:
            del _SERVED[self.path]
        if self.link_path:
            link = Path(self.link_path)
            if link.is_symlink() and os.readlink(link) == self.path:
                link.unlink()
        self._close_fds()

    def _close_fds(self) -> None:
        for fd in (self.master, self.slave, self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
