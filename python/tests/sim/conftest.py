"""Fixtures: a simulated bus served on a pseudo-terminal, opened with plain pyserial."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
import serial

from nurimc.sim import SimBus

EEPROM = 0.01  # a short EEPROM time keeps the tests quick; the busy behaviour is tested separately


class Pty:
    def __init__(self, bus: SimBus, link: Path) -> None:
        self.bus = bus
        self.link = link
        self.endpoint = bus.serve_pty(link=str(link))
        self.ports: list[serial.Serial] = []

    def open(self, baud: int = 9600) -> serial.Serial:
        port = serial.Serial(str(self.link), baud, timeout=0.3)
        self.ports.append(port)
        return port

    def close(self) -> None:
        for port in self.ports:
            port.close()
        self.endpoint.stop()
        self.bus.close()


@pytest.fixture
def make_pty(tmp_path: Path) -> Iterator[Callable[..., Pty]]:
    made: list[Pty] = []

    def build(controllers: list[tuple[int, int]] = [(0, 9600)], product: str = "mc", **bus_args: object) -> Pty:  # noqa: B006
        bus_args.setdefault("eeprom_time", EEPROM)
        bus = SimBus(**bus_args)  # type: ignore[arg-type]
        for ident, baud in controllers:
            bus.add_controller(ident, baud, product)
        pty = Pty(bus, tmp_path / f"bus{len(made)}")
        made.append(pty)
        return pty

    yield build
    for pty in made:
        pty.close()
