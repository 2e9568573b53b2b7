"""A transport over any pyserial-compatible port: device paths, socket://, rfc2217://, loop://,
and the schemes of the backend table (sim://, plugins: see backends.py)."""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import select
import socket
import struct
import time
from typing import Any, Literal, overload

import serial

from ..errors import FixedRate, NurimcError, PortError, RateRefused
from .backends import find_backend, known_schemes, scheme_of
from .base import Transport
from .latency import estimate_latency
from .rs485 import RS485, RtsDirection, enable_rs485, rs485_options

try:  # pyserial lets termios.error (not an OSError) out of tcsetattr on a refused rate
    import fcntl
    import termios

    TERMIOS_ERRORS: tuple[type[Exception], ...] = (termios.error,)
    #: the ioctl that tells how many bytes wait to be read (what pyserial's in_waiting asks)
    INQ: int | None = getattr(termios, "TIOCINQ", getattr(termios, "FIONREAD", None))
except ImportError:  # pragma: no cover - not POSIX
    TERMIOS_ERRORS = ()
    INQ = None
_ZERO = struct.pack("I", 0)
#: reads of one size in a row before select() is told to wait for the whole size (_wake_at)
STEADY = 3
#: what setting a rate may raise (pyserial, the OS, termios)
SET_RATE_ERRORS: tuple[type[Exception], ...] = (serial.SerialException, OSError, ValueError, *TERMIOS_ERRORS)


def _what_came(fd: int, max_bytes: int) -> bytes:
    """At a read's deadline with VMIN set: the bytes that came, fewer than VMIN (select() did
    not report them), by one non-blocking read."""
    try:
        data = os.read(fd, max_bytes)
    except BlockingIOError:
        return b""
    if not data:
        raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
    return data


def refuses_rate(err: Exception) -> bool:
    """Does this error from setting a rate say the adapter cannot do that rate (EINVAL), rather
    than that the port is gone? pyserial raises ValueError for a custom rate the driver refuses,
    termios.error/OSError with EINVAL for a standard one, SerialException wrapping either."""
    if isinstance(err, ValueError):
        return True
    code = getattr(err, "errno", None)
    if code is None and err.args and isinstance(err.args[0], int):
        code = err.args[0]
    text = str(err)
    return code == errno.EINVAL or "Errno 22" in text or "Invalid argument" in text or "parameter is incorrect" in text


def _port_error(url: str, err: Exception) -> PortError:
    """Translate pyserial/OS errors into one line that says what to do."""
    code = getattr(err, "errno", None)
    text = str(err)
    if code == errno.ENOENT or "No such file" in text or ("could not open port" in text and "[Errno 2]" in text):
        return PortError(
            f"port {url} not found: check the adapter is plugged in and the path is right "
            "(list ports with `python -m serial.tools.list_ports`)"
        )
    if code == errno.EACCES or "Permission denied" in text or "[Errno 13]" in text:
        return PortError(
            f"permission denied on {url}: add your user to the dialout group "
            "(`sudo usermod -aG dialout $USER`, then log out and back in)"
        )
    if code in (errno.EBUSY, errno.EAGAIN) or "busy" in text.lower() or "[Errno 11]" in text:
        return PortError(f"port {url} is busy: another program has it open; close that program first")
    return PortError(f"cannot use port {url}: {text}")


#: schemes whose rate is the gateway's, whatever pyserial is told (rfc2217:// does change it)
FIXED_RATE_SCHEMES = ("socket",)


class SerialTransport:
    """Transport over a pyserial port. Reads on file-descriptor ports use select() directly,
    so a per-read timeout costs no termios reconfiguration."""

    def __init__(
        self, port: Any, url: str, latency: float | None = None, direction: RtsDirection | None = None
    ) -> None:
        self.port = port
        self.url = url
        #: RTS toggled around each write (RS485 without kernel support), or None
        self.direction = direction
        estimated, self.warning = estimate_latency(url)  # warning: e.g. a slow FTDI latency timer
        self.latency = estimated if latency is None else latency
        if self.warning:
            logging.getLogger("nurimc").warning(self.warning)
        #: a link whose rate the host cannot change (a TCP gateway, socket://): its rate, else None
        self.fixed_rate: int | None = int(port.baudrate) if scheme_of(url) in FIXED_RATE_SCHEMES else None
        self._fd: int | None = None
        try:
            self._fd = port.fileno()
        except (AttributeError, OSError, ValueError, NotImplementedError):
            self._fd = None
        #: a POSIX serial device or pty (pyserial's own class, non-blocking fd): written and asked
        #: for waiting bytes on its fd directly, a few system calls and pyserial's Python fewer a
        #: request (docs/performance.md); anything else goes through pyserial
        self._direct: int | None = self._fd if type(port) is serial.Serial and INQ is not None else None
        #: the terminal's VMIN as this transport last set it (-1: not known, set at the next read),
        #: and the size the last reads asked for with how many in a row (see _wake_at)
        self._vmin = -1
        self._asked = (0, 0)

    @property
    def baudrate(self) -> int:
        return int(self.port.baudrate)

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        if self.fixed_rate is not None and rate != self.fixed_rate:
            raise FixedRate(
                f"{self.url} is a TCP gateway: its serial rate ({self.fixed_rate} bps) is set on the gateway, "
                f"not from here, so {rate} bps cannot be used",
                self.fixed_rate,
            )
        before = self.port.baudrate
        # pyserial writes the termios again, with its VMIN (0), but only if something else changed
        # (the same rate again: not written, our VMIN stays): not known, so set at the next read
        self._vmin = -1
        try:
            self.port.baudrate = rate
        except SET_RATE_ERRORS as err:
            if not refuses_rate(err):
                raise PortError(f"{self.url}: cannot set {rate} bps: {err}") from err
            with contextlib.suppress(*SET_RATE_ERRORS):  # the port took the rate as its setting (pyserial):
                self.port.baudrate = before  # give it back the one it runs at
            raise RateRefused(f"the adapter at {self.url} cannot be set to {rate} bps ({err})") from err

    def write(self, data: bytes) -> None:
        try:
            if self.direction is not None:
                self.direction.write(self.port, data)
            elif self._direct is not None:
                try:
                    written = os.write(self._direct, data)
                except BlockingIOError:  # the output buffer is full: pyserial waits for room
                    written = 0
                if written < len(data):
                    self.port.write(data[written:])
            else:
                self.port.write(data)
        except (serial.SerialException, OSError) as err:
            raise _port_error(self.url, err) from err

    def read(self, max_bytes: int, timeout: float) -> bytes:
        try:
            if self._direct is not None:
                if self._asked[0] != max_bytes or self._vmin != max_bytes:
                    self._wake_at(self._direct, max_bytes)
                if self._vmin > 1:
                    return self._read_whole(self._direct, max_bytes, timeout)
            if self._fd is not None:
                return self._read_fd(self._fd, max_bytes, timeout)
            if self.port.timeout != timeout:
                self.port.timeout = max(timeout, 0.0)
            return bytes(self.port.read(max_bytes))
        except (serial.SerialException, OSError) as err:
            raise _port_error(self.url, err) from err

    def _wake_at(self, fd: int, max_bytes: int) -> None:
        """Let select() wake this reader only once `max_bytes` have come (the terminal's VMIN,
        which the kernel's select honours with VTIME 0): an answer that comes in pieces, as they
        all do at wire speed, then costs one wake-up instead of one per piece (docs/performance.md).

        Set only for a size asked STEADY times in a row (a polling loop: set once), and back to
        pyserial's 0 as soon as another size is asked, so that a loop mixing sizes never changes
        the terminal at every read (on some USB adapters a change is a USB message). VMIN above
        what a read still needs would hold select() until the deadline: never left so."""
        size, count = self._asked
        count = count + 1 if size == max_bytes else 1
        self._asked = (max_bytes, count)
        want = max_bytes if count >= STEADY and 1 < max_bytes <= 255 else 0
        if want != self._vmin:
            try:
                attrs = termios.tcgetattr(fd)
                attrs[6][termios.VMIN] = want
                attrs[6][termios.VTIME] = 0
                termios.tcsetattr(fd, termios.TCSANOW, attrs)
            except termios.error as err:  # not an OSError: the port is gone (EIO), as a read would say
                raise OSError(*err.args) from err
            self._vmin = want

    @staticmethod
    def _read_whole(fd: int, max_bytes: int, timeout: float) -> bytes:
        """`_read_fd` when the terminal's VMIN is `max_bytes`: one select() until the whole of
        it has come or the deadline, then one read of what is there (a part, at the deadline)."""
        deadline = time.monotonic() + timeout
        if timeout > 0 and select.select([fd], [], [], timeout)[0]:
            data = os.read(fd, max_bytes)
            if not data:
                raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
            while len(data) < max_bytes:  # only where select() does not wait for VMIN bytes
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not select.select([fd], [], [], remaining)[0]:
                    return data + _what_came(fd, max_bytes - len(data))
                chunk = os.read(fd, max_bytes - len(data))
                if not chunk:
                    raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
                data += chunk
            return data
        return _what_came(fd, max_bytes)  # the deadline: select() waited for all of it

    @staticmethod
    def _read_fd(fd: int, max_bytes: int, timeout: float) -> bytes:
        deadline = time.monotonic() + timeout
        if timeout <= 0 or not select.select([fd], [], [], timeout)[0]:
            return b""
        data = os.read(fd, max_bytes)  # the first chunk: often the whole answer
        if not data:
            raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
        while len(data) < max_bytes:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not select.select([fd], [], [], remaining)[0]:
                break
            chunk = os.read(fd, max_bytes - len(data))
            if not chunk:
                raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
            data += chunk
        return data

    def discard_input(self) -> bytes:
        stale = b""
        try:
            if self._direct is not None:
                fd = self._direct
                while waiting := struct.unpack("I", fcntl.ioctl(fd, INQ or 0, _ZERO))[0]:
                    # read on the descriptor: pyserial's read() would wait in select() for VMIN bytes
                    chunk = os.read(fd, waiting)
                    if not chunk:
                        raise OSError(errno.EIO, "the port closed (adapter unplugged?)")
                    stale += chunk
                return stale  # the usual case: nothing waits (pyserial's in_waiting, without its Python)
            while self.port.in_waiting:
                stale += self.port.read(self.port.in_waiting)
        except (serial.SerialException, OSError) as err:
            raise _port_error(self.url, err) from err
        return stale

    def close(self) -> None:
        self._fd = self._direct = None  # its number may be another file's soon: pyserial says "not open"
        self.port.close()


def _no_delay(port: Any) -> None:
    """Send each write at once on a TCP port (socket://, rfc2217://: a serial server such as
    ser2net, the simulator's --tcp). pyserial leaves Nagle's algorithm on, which holds a small
    write back until the previous one is acknowledged; a request that gets no answer is acked
    only after the peer's delayed-ack timer (40 ms on Linux), so the requests written meanwhile
    reach the bus back to back in one segment and their answers collide (discovery's ID walk
    found a phantom ID where two controllers' answers overlapped)."""
    sock = getattr(port, "_socket", None)
    if isinstance(sock, socket.socket) and sock.family in (socket.AF_INET, socket.AF_INET6):
        with contextlib.suppress(OSError):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)


@overload
def open_transport(
    url: str,
    baudrate: int = ...,
    latency: float | None = ...,
    rs485: bool | str | RS485 | None = ...,
    reconnect: Literal[False] = ...,
) -> SerialTransport: ...


@overload
def open_transport(
    url: str, baudrate: int, latency: float | None, rs485: bool | str | RS485 | None, reconnect: bool
) -> Transport: ...


def open_transport(
    url: str,
    baudrate: int = 9600,
    latency: float | None = None,
    rs485: bool | str | RS485 | None = None,
    reconnect: bool = False,
) -> Transport:
    """Open a device path or port URL. rs485: RS485 direction control (see rs485.py), for
    adapters that do not switch between sending and receiving themselves. reconnect: reopen the
    port when it goes away (reconnect.py; calls fail fast with PortLost meanwhile)."""
    if reconnect:
        from .reconnect import ReconnectingTransport

        return ReconnectingTransport(url, lambda path, rate: open_transport(path, rate, latency, rs485), baudrate)
    direction_options = rs485_options(rs485)
    scheme = scheme_of(url)
    if direction_options is not None and scheme is not None:
        raise PortError(f"{url}: RS485 direction control needs a serial device; a {scheme}:// port has no RTS line")
    options: dict[str, Any] = {"baudrate": baudrate, "timeout": 0.1}
    try:
        opener = find_backend(url)
        if opener is not None:
            port = opener(url, **options)
        else:
            if scheme is None:
                options["exclusive"] = True  # two programs on one bus would garble each other
            port = serial.serial_for_url(url, **options)
    except NurimcError:
        raise  # already says what is wrong (e.g. a sim:// state directory that cannot be used)
    except (serial.SerialException, OSError, ValueError) as err:
        if "protocol" in str(err) and "not known" in str(err):
            raise PortError(f"{url}: unknown port scheme {scheme}://; known: {', '.join(known_schemes())}") from err
        raise _port_error(url, err) from err
    _no_delay(port)
    direction = None
    if direction_options is not None:
        try:
            direction = enable_rs485(port, direction_options, url)
        except PortError:
            port.close()
            raise
    return SerialTransport(port, url, latency, direction)
