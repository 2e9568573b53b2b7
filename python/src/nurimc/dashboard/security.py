"""Who may drive the motors: the listening address, the token, and Host / Origin checks.

A page from another site runs in the same browser as the console and can open websockets to
127.0.0.1. Browsers always send Origin on a websocket handshake, so the console accepts only
its own origin; the Host check stops DNS rebinding (a foreign name resolving to 127.0.0.1).
"""

from __future__ import annotations

import hmac
import ipaddress
from dataclasses import dataclass, field
from urllib.parse import urlsplit

DEFAULT_LISTEN = "127.0.0.1:8485"
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
TOKEN_COOKIE = "nurimc_token"


class ListenError(ValueError):
    """A --listen / --token combination the console refuses."""


@dataclass(frozen=True, slots=True)
class ListenAddress:
    host: str
    port: int

    @property
    def loopback(self) -> bool:
        if self.host == "localhost":
            return True
        try:
            return ipaddress.ip_address(self.host).is_loopback
        except ValueError:
            return False

    @property
    def wildcard(self) -> bool:
        return self.host in ("0.0.0.0", "::")


def parse_listen(text: str) -> ListenAddress:
    """'HOST:PORT', '[v6]:PORT' or ':PORT' (all addresses) -> ListenAddress (ListenError if malformed)."""
    text = text.strip()
    if text.startswith("["):
        host, _, rest = text[1:].partition("]")
        port_text = rest[1:] if rest.startswith(":") else ""
    else:
        host, _, port_text = text.rpartition(":")
        if ":" in host:
            raise ListenError(f"--listen {text!r}: write IPv6 addresses in brackets, e.g. [::1]:8485")
    host = host or "0.0.0.0"
    try:
        port = int(port_text)
    except ValueError:
        raise ListenError(f"--listen {text!r}: give HOST:PORT, e.g. 127.0.0.1:8485") from None
    if not 0 <= port <= 65535:
        raise ListenError(f"--listen {text!r}: port {port} is not 0..65535")
    return ListenAddress(host, port)


@dataclass(frozen=True)
class SecurityPolicy:
    """What a request must carry. Built once from the command line."""

    listen: ListenAddress
    token: str | None = None
    extra_hosts: tuple[str, ...] = field(default=())
    #: `--allow-any-port`: the page may open any port URL (files and network as the server's user)
    any_port: bool = False

    @classmethod
    def build(
        cls, listen: ListenAddress, token: str | None, extra_hosts: tuple[str, ...] = (), any_port: bool = False
    ) -> SecurityPolicy:
        if token is not None and len(token) < 16:
            raise ListenError(
                "--token must be at least 16 characters "
                "(e.g. `python3 -c 'import secrets; print(secrets.token_urlsafe())'`)"
            )
        if not listen.loopback and not token:
            raise ListenError(
                f"listening on {listen.host} lets other machines drive the motors: give --token SECRET "
                "(at least 16 characters), or listen on 127.0.0.1"
            )
        return cls(listen, token, extra_hosts, any_port)

    def host_allowed(self, host_header: str | None) -> bool:
        """The Host header names this server (not a rebinding name)."""
        if not host_header:
            return False
        name = urlsplit(f"//{host_header}").hostname or ""
        if name in LOOPBACK_NAMES or name in self.extra_hosts or name == self.listen.host:
            return True
        # On a wildcard address the machine has names we cannot list; the token guards it.
        return self.listen.wildcard and self.token is not None

    def origin_allowed(self, origin: str | None, host_header: str | None) -> bool:
        """The websocket comes from a page this server served (same scheme-less host:port)."""
        if not origin or not host_header:
            return False
        parts = urlsplit(origin)
        return parts.scheme in ("http", "https") and parts.netloc.lower() == host_header.lower()

    def port_refusal(self, url: str) -> str | None:
        """Why the page may not open this port (None: it may). See port_refusal() below."""
        return None if self.any_port else port_refusal(url)

    def token_ok(self, presented: str | None) -> bool:
        if self.token is None:
            return True
        return presented is not None and hmac.compare_digest(presented.encode(), self.token.encode())


#: sim:// options that touch files (the simulator's state directory)
SIM_FILE_OPTIONS = ("state",)
_DEVICE_PREFIXES = ("/dev/",)
ALLOW_ANY_PORT = "--allow-any-port"


def port_refusal(url: str) -> str | None:
    """Why a page may not open this port URL, or None if it may (docs/dashboard.md, "What the page may open").

    A page may open serial devices (/dev/..., COMn) and the simulator (sim:// without a state
    directory). Every other URL (spy:// writes a file, socket:// and rfc2217:// reach the network,
    loop://, alt://, hwgrep://, plug-in schemes) needs the server started with --allow-any-port."""
    text = url.strip()
    if any(ord(ch) < 32 for ch in text):
        return "the port name holds control characters"
    head, sep, _rest = text.partition("://")
    if not sep:
        if _is_windows_port(text):
            return None
        if (text.startswith(_DEVICE_PREFIXES) and "/../" not in text + "/") or _links_to_serial_device(text):
            return None
        return f"{text!r} is not a serial device: the page opens /dev/... devices (or COMn) and sim://"
    scheme = head.lower()
    if scheme == "sim":
        from urllib.parse import parse_qs, urlsplit

        try:
            options = parse_qs(urlsplit(text).query, keep_blank_values=True)
        except ValueError as error:  # e.g. an unclosed '[' reads as a broken IPv6 address
            return f"{text!r} is not a URL the simulator takes ({error}): give sim://?ids=1,2"
        touching = sorted(name for name in options if name.lower() in SIM_FILE_OPTIONS)
        if touching:
            return (
                f"sim:// option {', '.join(touching)} writes files on the server: "
                f"not from the page unless the console was started with {ALLOW_ANY_PORT}"
            )
        return None
    return (
        f"{scheme}:// ports reach files or the network as the server's user: "
        f"not from the page unless the console was started with {ALLOW_ANY_PORT}"
    )


def _links_to_serial_device(path: str) -> bool:
    """A name elsewhere (`nurimc sim --link /tmp/nurimc0`, a udev alias) for a terminal device:
    the link itself must resolve to a character device under /dev that is a serial terminal."""
    import os
    import stat

    target = os.path.realpath(path)
    if not target.startswith(_DEVICE_PREFIXES):
        return False
    try:
        mode = os.stat(target).st_mode
    except OSError:
        return False
    name = target.removeprefix("/dev/")
    return stat.S_ISCHR(mode) and name.startswith(("tty", "pts/", "cu.", "rfcomm", "serial/"))


def _is_windows_port(text: str) -> bool:
    name = text.upper().removeprefix("\\\\.\\")
    return name.startswith("COM") and name[3:].isdigit()


def security_headers(host: str | None) -> list[tuple[bytes, bytes]]:
    """Headers on every HTTP answer: no framing (clickjacking), scripts only from the console itself."""
    sockets = f" ws://{host} wss://{host}" if host else ""
    policy = (
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        f"connect-src 'self'{sockets}; object-src 'none'; base-uri 'none'; form-action 'self'; "
        "frame-ancestors 'none'"
    )
    return [
        (b"x-frame-options", b"DENY"),
        (b"content-security-policy", policy.encode("latin-1")),
        (b"x-content-type-options", b"nosniff"),
        (b"referrer-policy", b"no-referrer"),
    ]
