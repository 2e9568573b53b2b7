"""Which code opens a port URL: a small table of URL schemes (python-can's BACKENDS, in spirit).

A scheme maps to "module:callable"; the module is imported only when such a URL is opened, so
the transport layer imports no backend (the simulator included) until it is asked for one.
The callable takes (url, baudrate=..., timeout=...) and returns an open, pyserial-compatible
port. Anything not in the table (device paths, socket://, rfc2217://, loop://) goes to
pyserial's serial_for_url. Other packages add schemes with an entry point in the group
"nurimc.transports" (name = scheme, value = "module:callable"), or at run time with
register_backend().
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any

PortOpener = Callable[..., Any]
ENTRY_POINT_GROUP = "nurimc.transports"

#: scheme -> "module:callable"
BACKENDS: dict[str, str] = {
    "sim": "nurimc.sim.urlhandler.protocol_sim:Serial",  # the simulator, in-process
}
_registered: dict[str, PortOpener] = {}


def register_backend(scheme: str, opener: PortOpener) -> None:
    """Open `scheme://...` URLs with `opener(url, baudrate=..., timeout=...)` from now on."""
    _registered[scheme.lower()] = opener


def scheme_of(url: str) -> str | None:
    head, sep, _ = url.partition("://")
    return head.lower() if sep else None


def _load(target: str) -> PortOpener:
    module, _, name = target.partition(":")
    opener: PortOpener = getattr(importlib.import_module(module), name)
    return opener


def find_backend(url: str) -> PortOpener | None:
    """The opener for this URL's scheme, or None for pyserial's own (device paths included)."""
    scheme = scheme_of(url)
    if scheme is None:
        return None
    if scheme in _registered:
        return _registered[scheme]
    if scheme in BACKENDS:
        return _load(BACKENDS[scheme])
    for entry in entry_points(group=ENTRY_POINT_GROUP, name=scheme):
        opener: PortOpener = entry.load()
        return opener
    return None


def known_schemes() -> list[str]:
    """Every scheme we can open: ours, registered ones, entry points, and pyserial's URL handlers."""
    pyserial = ["socket", "rfc2217", "loop", "spy", "alt", "hwgrep", "cp2110"]
    plugins = [entry.name for entry in entry_points(group=ENTRY_POINT_GROUP)]
    return sorted({*BACKENDS, *_registered, *plugins, *pyserial})
