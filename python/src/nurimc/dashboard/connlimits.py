"""The console's HTTP connections under a flood of half-open or idle ones (docs/dashboard.md, "Connection limits").

uvicorn has a keep-alive timeout but no time limit on reading a request's headers, and its
`limit_concurrency` answers 503 to everyone (the page included) once the attacker holds the
connections. Here, instead:

- a connection that has not completed a request's headers within HEADER_TIMEOUT is closed
  (and so is one idle that long between requests);
- connections are counted per client address and in total; at a cap the *oldest idle*
  connection (no request in progress: half-open ones first in line) of the busiest address is
  closed to make room, so a new page still loads and an open page's websocket (never idle in
  this sense: it is no longer an HTTP connection) is never the one closed;
- the total cap stays below the process's file-descriptor limit (raised to its hard limit at
  start-up), so accept() does not run out; if it still does (EMFILE), one line is logged per
  minute instead of a traceback every second.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import resource
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from uvicorn.protocols.http.h11_impl import H11Protocol

HEADER_TIMEOUT = 10.0  # s to send a complete request's headers (and the longest idle time between requests)
KEEP_ALIVE = 5.0  # s uvicorn keeps an idle keep-alive connection
MAX_HEADER_BYTES = 16 * 1024  # a request's line + headers; more is answered 400 by h11
MAX_PER_ADDRESS = 512  # connections from one client address
MAX_TOTAL = 4096  # connections in all (also kept FD_RESERVE under the file-descriptor limit)
FD_RESERVE = 256  # descriptors kept for the bus, files, the loop itself
EMFILE_LOG_EVERY = 60.0  # s between "out of file descriptors" lines
log = logging.getLogger("nurimc.dashboard")


def raise_fd_limit() -> int:
    """Raise the soft file-descriptor limit to the hard one; the soft limit in force afterwards."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and soft < hard:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
        except (ValueError, OSError):
            pass
    return int(soft) if soft != resource.RLIM_INFINITY else 1 << 20


@dataclass
class ConnectionLimits:
    """The shared count of open connections, by client address."""

    per_address: int = MAX_PER_ADDRESS
    total: int = MAX_TOTAL
    header_timeout: float = HEADER_TIMEOUT
    by_address: dict[str, dict[asyncio.BaseTransport, GuardedH11Protocol]] = field(default_factory=dict)
    count: int = 0
    closed_idle: int = 0  # connections closed for being idle/half-open too long
    evicted: int = 0  # connections closed at a cap to make room
    refused: int = 0  # new connections closed at a cap (nothing idle to close)

    @classmethod
    def for_this_process(cls) -> ConnectionLimits:
        fds = raise_fd_limit()
        return cls(total=max(64, min(MAX_TOTAL, fds - FD_RESERVE)))

    def admit(self, transport: asyncio.BaseTransport, protocol: GuardedH11Protocol, address: str) -> bool:
        """Count a new connection, making room at a cap; False: refused (the caller closes it)."""
        here = self.by_address.setdefault(address, {})
        if len(here) >= self.per_address:
            self._purge(address)
            if len(here) >= self.per_address and not self._evict(address):
                self.refused += 1
                return False
        if self.count >= self.total:
            for name in list(self.by_address):
                self._purge(name)
            if self.count >= self.total:
                busiest = max(self.by_address, key=lambda name: len(self.by_address[name]))
                if not self._evict(busiest):
                    self.refused += 1
                    return False
        here[transport] = protocol
        self.count += 1
        return True

    def release(self, transport: asyncio.BaseTransport, address: str) -> None:
        here = self.by_address.get(address)
        if here is not None and here.pop(transport, None) is not None:
            self.count -= 1
            if not here:
                del self.by_address[address]

    def _purge(self, address: str) -> None:
        """Forget connections already closed (a websocket's ends without telling us)."""
        here = self.by_address.get(address, {})
        for transport in [t for t in here if t.is_closing()]:
            self.release(transport, address)

    def _evict(self, address: str) -> bool:
        """Close the oldest idle connection from this address (insertion order is age)."""
        for transport, protocol in self.by_address.get(address, {}).items():
            if transport.get_protocol() is protocol and protocol.idle():
                self.release(transport, address)
                transport.close()
                self.evicted += 1
                return True
        return False


class GuardedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol with a header timeout and the connection caps (see the module)."""

    limits: ConnectionLimits  # set on the subclass guarded_protocol() makes

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._address = self.client[0] if self.client else "?"
        self._timer: asyncio.TimerHandle | None = None
        if not self.limits.admit(transport, self, self._address):
            transport.close()
            return
        self._arm()

    def idle(self) -> bool:
        """No request in progress: half-open (headers not complete) or between requests."""
        return self.cycle is None or self.cycle.response_complete

    def _arm(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
        self._timer = self.loop.call_later(self.limits.header_timeout, self._check)

    def _check(self) -> None:
        self._timer = None
        if self.transport.is_closing() or self.transport.get_protocol() is not self:
            return  # closed, or a websocket now (it has its own life)
        if self.idle():
            self.limits.closed_idle += 1
            self.transport.close()
        else:
            self._arm()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing():
            self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self.limits.release(self.transport, self._address)
        super().connection_lost(exc)


def guarded_protocol(limits: ConnectionLimits) -> type[GuardedH11Protocol]:
    return type("GuardedH11Protocol", (GuardedH11Protocol,), {"limits": limits})


def server_options(limits: ConnectionLimits) -> dict[str, Any]:
    """uvicorn.Config options for the limits above (merge with server.uvicorn_options())."""
    return {
        "http": guarded_protocol(limits),
        "timeout_keep_alive": KEEP_ALIVE,
        "h11_max_incomplete_event_size": MAX_HEADER_BYTES,
    }


def quiet_emfile(loop: asyncio.AbstractEventLoop, now: Callable[[], float] = time.monotonic) -> None:
    """Out of file descriptors at accept(): one line a minute, not a traceback every second."""
    previous = loop.get_exception_handler()
    last = [-EMFILE_LOG_EVERY]

    def handler(loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        error = context.get("exception")
        if isinstance(error, OSError) and error.errno in (errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM):
            if now() - last[0] >= EMFILE_LOG_EVERY:
                last[0] = now()
                print(
                    f"dashboard: out of file descriptors accepting connections ({error.strerror}); "
                    "new connections wait until some close",
                    file=sys.stderr,
                )
            return
        if previous is not None:
            previous(loop, context)
        else:
            loop.default_exception_handler(context)

    loop.set_exception_handler(handler)
