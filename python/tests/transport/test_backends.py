"""The table of URL schemes: sim:// and plugins open through it, not through pyserial globals."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import EntryPoint
from typing import Any

import pytest
import serial

from nurimc import Bus, PortError
from nurimc.transport import backends, open_transport, register_backend


class LoopPort:
    """Opened by a test backend: records how it was asked, echoes what is written."""

    def __init__(self, url: str, **options: Any) -> None:
        self.url, self.options = url, options
        self.baudrate = options["baudrate"]
        self.buffer = b""

    def write(self, data: bytes) -> int:
        self.buffer += data
        return len(data)

    def read(self, size: int) -> bytes:
        data, self.buffer = self.buffer[:size], self.buffer[size:]
        return data

    @property
    def in_waiting(self) -> int:
        return len(self.buffer)

    timeout = 0.1

    def close(self) -> None:
        pass


def test_a_registered_scheme_opens_with_its_backend(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(backends, "_registered", {})
    register_backend("Echo", LoopPort)
    transport = open_transport("echo://bench-1", baudrate=115200)
    assert isinstance(transport.port, LoopPort)
    assert transport.port.url == "echo://bench-1" and transport.port.options == {"baudrate": 115200, "timeout": 0.1}
    transport.write(b"\x01\x02")
    assert transport.read(2, 0.1) == b"\x01\x02"


def test_an_entry_point_adds_a_scheme(monkeypatch: pytest.MonkeyPatch) -> None:
    plugin = EntryPoint(name="plug", value=f"{__name__}:LoopPort", group=backends.ENTRY_POINT_GROUP)

    def fake_entry_points(group: str, name: str | None = None) -> list[EntryPoint]:
        assert group == backends.ENTRY_POINT_GROUP
        return [plugin] if name in (None, "plug") else []

    monkeypatch.setattr(backends, "entry_points", fake_entry_points)
    assert isinstance(open_transport("plug://x").port, LoopPort)
    assert "plug" in backends.known_schemes()


def test_sim_opens_without_pyserial_url_handlers(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(serial, "protocol_handler_packages", ["serial.urlhandler"])
    with Bus.open("sim://?ids=0,3&baud=9600") as bus:
        assert bus.motor(3).ping()


def test_unknown_scheme_names_the_known_ones() -> None:
    with pytest.raises(PortError, match=r"unknown port scheme nope://; known: .*loop.*sim.*socket"):
        Bus.open("nope://host")


def test_the_transport_layer_imports_no_backend() -> None:
    probe = "import sys, nurimc.transport; print(sorted(m for m in sys.modules if m.startswith('nurimc.sim')))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=60)
    assert out.stdout.strip() == "[]"
