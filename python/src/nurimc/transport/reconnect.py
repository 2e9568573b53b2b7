"""A transport that survives its port going away: `Bus.open(url, reconnect=True)`.

A USB-RS485 adapter that resets (EMI, a loose cable) makes the port fail with EIO, ENXIO, a
broken pipe or "device disconnected", and the device file vanishes until the adapter
re-enumerates. This wrapper notices that once, says so in one line (the "nurimc" logger and
every watcher), closes the dead port and reopens the same path in a background thread with
backoff (never a busy loop). While the port is down every call fails at once with PortLost, so
no caller waits out timeouts on a dead port and nothing asked meanwhile is sent later by
surprise. When the port is back, frames registered with `on_return` (pending stops) are
written first, before any other traffic; then watchers hear "back" and callers go on.

Following the adapter: the same path is reopened. Give the `/dev/serial/by-id/...` name of an
adapter and the reopen follows it wherever it re-enumerates (ttyUSB0 today, ttyUSB1 after a
reset). Given a plain `/dev/ttyUSBn`, the by-id names that pointed to it when it was first
opened are tried as well once that path is gone (docs/library.md, "Reconnect").
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

from ..errors import PortError, PortLost
from .base import Transport

#: first reopen attempt after a loss, and the longest pause between attempts (doubled each time):
#: an attempt is one open() that fails at once, so a few a second cost nothing, and the port is
#: in use again at most BACKOFF_MAX (0.1 s) after it returns (a stop owed goes out then)
BACKOFF_FIRST = 0.05
BACKOFF_MAX = 0.1
BY_ID = Path("/dev/serial/by-id")

log = logging.getLogger("nurimc")

T = TypeVar("T")
Opener = Callable[[str, int], Transport]  # (path, baudrate) -> an open transport, PortError if not


@dataclass(frozen=True, slots=True)
class PortEvent:
    """What a watcher hears: the port was `lost` or is `back` (`down_for` seconds after the loss)."""

    kind: str  # "lost" | "back"
    url: str
    text: str  # one line for people
    at: float  # time.monotonic() of the event
    down_for: float | None = None
    sent_first: tuple[str, ...] = field(default=())  # keys of the on_return frames written first


# errno values that mean the device itself is gone, not that one call was wrong
_LOSS_ERRNOS = {
    errno.EIO,
    errno.ENXIO,
    errno.ENODEV,
    errno.ENOENT,
    errno.EPIPE,
    errno.EBADF,
    errno.ECONNRESET,
    errno.ECONNABORTED,
    errno.ECONNREFUSED,
    errno.ESHUTDOWN,
    errno.ENOTCONN,
}


def is_loss(error: BaseException) -> bool:
    """Does this failure (a PortError and its cause) mean the port is gone?"""
    cause = error.__cause__ if isinstance(error, PortError) else error
    if cause is None:
        return isinstance(error, PortError)
    if isinstance(cause, ValueError):  # a bad argument (an unsupported rate): the port is fine
        return False
    code = getattr(cause, "errno", None)
    if code in _LOSS_ERRNOS:
        return True
    text = str(cause).lower()
    hints = ("disconnected", "input/output error", "broken pipe", "not open", "no such", "closed", "reset by peer")
    return any(hint in text for hint in hints) or type(cause).__name__ == "SerialException"


def by_id_names(path: str, directory: Path = BY_ID) -> list[str]:
    """The /dev/serial/by-id links that point to this device now (empty if none, or not a device)."""
    if "://" in path or not directory.is_dir():
        return []
    try:
        target = os.path.realpath(path)
        return sorted(
            str(link) for link in directory.iterdir() if os.path.realpath(link) == target and str(link) != path
        )
    except OSError:
        return []


def _one_line(error: BaseException) -> str:
    text = str(error.__cause__ or error) if isinstance(error, PortError) else str(error)
    return " ".join(text.split()) or type(error).__name__


class ReconnectingTransport:
    """A Transport that reopens its port after a loss (see the module docstring)."""

    def __init__(
        self,
        url: str,
        opener: Opener,
        baudrate: int = 9600,
        backoff: tuple[float, float] = (BACKOFF_FIRST, BACKOFF_MAX),
    ) -> None:
        self.url = url
        self._opener = opener
        self._rate = baudrate
        self._backoff = backoff
        self._inner: Transport | None = opener(url, baudrate)  # the first open fails as a plain open would
        self.latency = self._inner.latency
        self.warning: str | None = getattr(self._inner, "warning", None)
        self._aliases = by_id_names(url)
        self._lock = threading.RLock()  # guards _inner; never held while waiting for a reopen
        self._up = threading.Event()
        self._up.set()
        self._closing = threading.Event()
        self._kick = threading.Event()  # set: stop waiting, try now (retry_now, close)
        self._thread: threading.Thread | None = None
        self._watchers: list[Callable[[PortEvent], None]] = []
        self._on_return: dict[str, bytes] = {}
        #: when the port was lost (time.monotonic()), and why, while it is down
        self.lost_at: float | None = None
        self.cause = ""
        self.losses = 0  # times the port was lost
        self.returns = 0  # times it came back
        self.last_attempt_error = ""  # why the latest reopen failed

    # -- state -------------------------------------------------------------------------------
    @property
    def up(self) -> bool:
        return self._up.is_set()

    def wait_up(self, timeout: float | None = None) -> bool:
        """Block until the port is up (True) or `timeout` seconds pass (False). No busy loop."""
        return self._up.wait(timeout)

    def watch(self, callback: Callable[[PortEvent], None]) -> None:
        """Call `callback(PortEvent)` on every loss and return (from the thread that saw it)."""
        self._watchers.append(callback)

    def unwatch(self, callback: Callable[[PortEvent], None]) -> None:
        with contextlib.suppress(ValueError):
            self._watchers.remove(callback)

    def on_return(self, key: str, frames: bytes | None) -> None:
        """Frames to write first when the port comes back (a stop that could not be sent), under
        `key`; None withdraws them. Written once, in key order, then forgotten."""
        with self._lock:
            if frames is None:
                self._on_return.pop(key, None)
            else:
                self._on_return[key] = frames

    @property
    def pending_on_return(self) -> dict[str, bytes]:
        with self._lock:
            return dict(self._on_return)

    def lost_text(self) -> str:
        down = time.monotonic() - self.lost_at if self.lost_at is not None else 0.0
        return (
            f"port {self.url} is lost ({self.cause}) and being reopened (down {down:.1f} s); "
            "nothing was sent: try again when it is back"
        )

    # -- Transport ---------------------------------------------------------------------------
    @property
    def baudrate(self) -> int:
        return self._rate

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        """Kept while the port is down and applied when it is reopened."""
        with self._lock:
            inner = self._inner
            if inner is not None:
                self._guard(inner, lambda: setattr(inner, "baudrate", rate))
            self._rate = rate

    def write(self, data: bytes) -> None:
        inner = self._current()
        self._guard(inner, lambda: inner.write(data))

    def read(self, max_bytes: int, timeout: float) -> bytes:
        inner = self._current()
        data: bytes = self._guard(inner, lambda: inner.read(max_bytes, timeout))
        return data

    def discard_input(self) -> bytes:
        inner = self._current()
        data: bytes = self._guard(inner, inner.discard_input)
        return data

    def close(self) -> None:
        self._closing.set()
        self._kick.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5)
        with self._lock:
            inner, self._inner = self._inner, None
        if inner is not None:
            with contextlib.suppress(PortError, OSError):
                inner.close()

    # -- loss and return ---------------------------------------------------------------------
    def _current(self) -> Transport:
        inner = self._inner
        if inner is None or not self._up.is_set():
            if self._closing.is_set():
                raise PortError(f"port {self.url} is closed")
            raise PortLost(self.lost_text())
        return inner

    def _guard(self, inner: Transport, call: Callable[[], T]) -> T:
        try:
            return call()
        except PortError as error:
            if not is_loss(error) or self._closing.is_set():
                raise
            self._lose(inner, error)
            raise PortLost(self.lost_text()) from error
        except OSError as error:  # a transport that lets OS errors through
            if errno_of(error) not in _LOSS_ERRNOS or self._closing.is_set():
                raise
            self._lose(inner, error)
            raise PortLost(self.lost_text()) from error

    def _lose(self, inner: Transport, error: BaseException) -> None:
        with self._lock:
            if self._inner is not inner:  # another thread saw it first: said once
                return
            self._inner = None
            self._up.clear()
            self.lost_at = time.monotonic()
            self.cause = _one_line(error)
            self.losses += 1
            with contextlib.suppress(PortError, OSError, Exception):
                inner.close()
            self._thread = threading.Thread(target=self._reopen_loop, name="nurimc-reconnect", daemon=True)
            self._thread.start()
        text = f"port {self.url} lost ({self.cause}); reopening it in the background"
        self._tell(PortEvent("lost", self.url, text, self.lost_at))

    def retry_now(self) -> None:
        """Try to reopen at once instead of at the next backoff step (a person asked for it)."""
        self._kick.set()

    def _reopen_loop(self) -> None:
        delay, longest = self._backoff
        while True:
            self._kick.wait(delay)
            self._kick.clear()
            if self._closing.is_set():
                return
            inner = self._try_open()
            if inner is not None and self._come_back(inner):
                return
            delay = min(delay * 2, longest)

    def _try_open(self) -> Transport | None:
        for path in [self.url, *self._aliases]:
            try:
                return self._opener(path, self._rate)
            except PortError as error:
                self.last_attempt_error = _one_line(error)
            except Exception as error:  # never a traceback from the background thread
                self.last_attempt_error = f"{type(error).__name__}: {error}"
        return None

    def _come_back(self, inner: Transport) -> bool:
        with self._lock:
            if self._closing.is_set():
                with contextlib.suppress(Exception):
                    inner.close()
                return True
            sent: list[str] = []
            try:
                with contextlib.suppress(PortError, OSError):
                    inner.discard_input()  # what the adapter held from before is stale
                for key in sorted(self._on_return):
                    inner.write(self._on_return[key])
                    sent.append(key)
            except (PortError, OSError) as error:  # gone again at once: keep trying
                self.last_attempt_error = _one_line(error)
                with contextlib.suppress(Exception):
                    inner.close()
                return False
            for key in sent:
                del self._on_return[key]
            self._inner = inner
            self.latency = inner.latency
            self.returns += 1
            lost_at = self.lost_at or time.monotonic()
            now = time.monotonic()
            self.lost_at = None
            self._up.set()
        first = f"; sent first: {', '.join(sent)}" if sent else ""
        text = f"port {self.url} is back after {now - lost_at:.1f} s{first}"
        self._tell(PortEvent("back", self.url, text, now, now - lost_at, tuple(sent)))
        return True

    def _tell(self, event: PortEvent) -> None:
        # a watcher says it (the tools); without one, Python's last-resort handler shows the warning
        loud = event.kind == "lost" and not self._watchers
        (log.warning if loud else log.info)(event.text)
        for watcher in list(self._watchers):
            try:
                watcher(event)
            except Exception as error:  # a watcher's bug must not stop the reconnect
                log.error("port watcher failed: %s: %s", type(error).__name__, error)


def errno_of(error: BaseException) -> int | None:
    code = getattr(error, "errno", None)
    return code if isinstance(code, int) else None


def reconnecting(transport: Transport) -> ReconnectingTransport | None:
    """The transport as a ReconnectingTransport, or None if it was opened without reconnect."""
    return transport if isinstance(transport, ReconnectingTransport) else None
