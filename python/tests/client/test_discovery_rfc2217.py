"""Discovery over RFC 2217 (rfc2217://): the simulator's TCP port sets each client's rate, so
controllers at several rates are found over TCP, each once at its own rate (unlike socket://,
a link at one rate: tests/client/test_discovery_tcp.py)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from collections.abc import Iterator

from nurimc import Bus
from nurimc.procedures.discovery import FixedLink, Found, discover
from nurimc.sim import SimBus

from ..cli.inprocess import nurimc

#: ID -> (rate, product): three rates, two product lines
MOTORS = {1: (9600, "mc"), 7: (57600, "rsa"), 9: (115200, "mc")}


@contextlib.contextmanager
def rfc2217_sim() -> Iterator[str]:
    """`nurimc sim --tcp 0 --motor 1@9600:mc --motor 7@57600:rsa --motor 9@115200:mc`, in-process;
    yields its rfc2217:// URL."""
    sim = SimBus()
    for device_id, (rate, product) in MOTORS.items():
        sim.add_controller(device_id, baud=rate, product=product)
    server = sim.serve_tcp(host="127.0.0.1", port=0, baud=9600)
    try:
        yield f"rfc2217://{server.address[0]}:{server.address[1]}"
        assert server.alive and server.errors == 0
    finally:
        server.stop()
        sim.close()


def test_discovery_over_rfc2217_finds_three_rates_once_each() -> None:
    with rfc2217_sim() as url:
        bus = Bus.open(url, 9600)
        notes: list[object] = []
        try:
            found: list[Found] = bus.run(discover(bus.core), on_note=notes.append)
            assert bus.baudrate == 9600  # left at its old rate
        finally:
            bus.close()
    assert sorted((f.id, f.baudrate, f.line, f.collision) for f in found) == [
        (1, 9600, "mc", False),
        (7, 57600, "rsa", False),
        (9, 115200, "mc", False),
    ]
    assert not [n for n in notes if isinstance(n, FixedLink)]  # rfc2217:// is not a fixed-rate link


@contextlib.contextmanager
def rfc2217_sim_process() -> Iterator[str]:
    """The same bus from the command line, `nurimc sim --tcp 0 --motor ...` (its ready line read)."""
    motors = [arg for i, (rate, product) in MOTORS.items() for arg in ("--motor", f"{i}@{rate}:{product}")]
    proc = subprocess.Popen(
        [sys.executable, "-m", "nurimc.sim", "--tcp", "0", "--ids", "", *motors],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stdout is not None
    try:
        seen = []
        for line in proc.stdout:
            seen.append(line)
            if line.startswith("ready: "):
                yield "rfc2217://" + line.removeprefix("ready: ").strip()
                break
        else:
            raise AssertionError(f"nurimc sim printed no ready line: {seen}")
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)


def test_nurimc_scan_over_rfc2217_lists_each_controller_once() -> None:
    with rfc2217_sim_process() as url:
        result = nurimc("--port", url, "scan", "--expect", "3")
    assert result.code == 0, result.err
    rows = [line.split("│") for line in result.out.splitlines() if line.startswith("│")]
    seen = sorted((int(row[1]), int(row[2]), row[4].strip()) for row in rows)
    assert seen == [(1, 9600, "mc"), (7, 57600, "rsa"), (9, 115200, "mc")], result.out
    assert "TCP gateway" not in result.out + result.err
