"""A simulated bus behind a port that tests cut and restore (nurimc.sim.faultproxy)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from nurimc.protocol import StreamParser
from nurimc.protocol.message import Message
from nurimc.sim import SimBus
from nurimc.sim.faultproxy import FaultProxy

BAUD = 115200
WIRE = True


@contextmanager
def cuttable_bus(kind: str, tmp: Path, ids: tuple[int, ...] = (1,)) -> Iterator[tuple[SimBus, FaultProxy]]:
    """A simulator with `ids` at BAUD, served over TCP, behind a FaultProxy of `kind` (pty or tcp)."""
    sim = SimBus(wire_timing=WIRE)
    for device_id in ids:
        sim.add_controller(id=device_id, baud=BAUD)
    server = sim.serve_tcp(port=0, baud=BAUD)
    proxy = FaultProxy(
        server.address, link=str(tmp / "ttyCut") if kind == "pty" else None, tcp_port=None if kind == "pty" else 0
    )
    proxy.start()
    try:
        yield sim, proxy
    finally:
        proxy.stop()
        server.stop()
        sim.close()


def frames_after_cut(proxy: FaultProxy, cuts: int = 1) -> list[Message]:
    """The frames the host sent once the port came back after cut number `cuts`."""
    parser = StreamParser()
    return [m for n, data in proxy.from_host if n >= cuts for m in parser.feed(data)]
