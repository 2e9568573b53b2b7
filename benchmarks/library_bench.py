#!/usr/bin/env python3
"""Benchmarks of the host library against the simulator on a real pseudo-terminal.

1. Transaction latency: the library's request/answer against a bare pyserial write-and-read
   of the same bytes on the same pseudo-terminal, interleaved in one run (goal: ratio <= 1.3).
2. Discovery: 3 controllers at rates unknown to the host, wire timing on (goal: < 15 s).
3. Control cycle: 8 motors at 1 Mbps with wire timing, command all + read all, against the
   wire-limited maximum (goal: >= 0.8 of it); sequential reads and one staggered broadcast read.

Usage: python benchmarks/library_bench.py [--quick]   (writes benchmarks/results/library.json)
"""

from __future__ import annotations

import json
import platform
import statistics
import sys
import time
from pathlib import Path

import serial

from nurimc import Bus, Group
from nurimc.discovery import discover
from nurimc.protocol import RequestPosition
from nurimc.sim import SimBus

RESULTS = Path(__file__).resolve().parent / "results" / "library.json"
WIRE_BITS = 10


def latency(rounds: int) -> dict[str, float]:
    sim = SimBus()
    sim.add_controller(id=1, baud=1_000_000)
    endpoint = sim.serve_pty()
    request = RequestPosition(1)
    frame = request.encode()
    raw_port = serial.Serial(endpoint.path, 1_000_000, timeout=1)
    bus = Bus.open(endpoint.path, baudrate=1_000_000)
    bare, library = [], []
    for _ in range(rounds):  # interleaved, so both see the same machine load
        start = time.perf_counter()
        raw_port.write(frame)
        assert len(raw_port.read(12)) == 12
        bare.append(time.perf_counter() - start)
        start = time.perf_counter()
        bus.request(request)
        library.append(time.perf_counter() - start)
    raw_port.close()
    bus.close()
    endpoint.stop()
    sim.close()
    b, lib = statistics.median(bare), statistics.median(library)
    return {
        "bare_pyserial_median_us": round(b * 1e6, 1),
        "library_median_us": round(lib * 1e6, 1),
        "ratio": round(lib / b, 3),
        "rounds": rounds,
    }


def discovery() -> dict[str, float]:
    rates = {12: 19200, 77: 230400, 200: 1_000_000}
    sim = SimBus(wire_timing=True)
    for device_id, rate in rates.items():
        sim.add_controller(id=device_id, baud=rate)
    endpoint = sim.serve_pty()
    bus = Bus.open(endpoint.path, baudrate=9600)
    start = time.perf_counter()
    found = bus.run(discover(bus.core))
    elapsed = time.perf_counter() - start
    bus.close()
    endpoint.stop()
    sim.close()
    assert sorted((f.id, f.baudrate) for f in found) == sorted(rates.items()), found
    return {"seconds": round(elapsed, 3), "controllers": len(found), "rates_searched": 18}


def control_cycle(seconds: float) -> dict[str, float]:
    ids = list(range(1, 9))
    sim = SimBus(wire_timing=True)
    for device_id in ids:
        sim.add_controller(id=device_id, baud=1_000_000)
    endpoint = sim.serve_pty()
    bus = Bus.open(endpoint.path, baudrate=1_000_000)
    group = Group(bus, ids)
    commands = [m.make_move_to(10.0, rpm=60) for m in group.motors]
    command_bytes = sum(len(c.encode()) for c in commands)
    response = 100e-6

    def run(read, command) -> float:  # type: ignore[no-untyped-def]
        cycles, end = 0, time.perf_counter() + seconds
        start = time.perf_counter()
        while time.perf_counter() < end:
            command()
            states = read()
            assert len(states) == len(ids)
            cycles += 1
        return cycles / (time.perf_counter() - start)

    frames = b"".join(c.encode() for c in commands)
    requests = [RequestPosition(i).encode() for i in ids]
    raw = bus.transport.port  # the same open port, driven by bare pyserial calls: the best a host can do here

    def bare_read() -> list[bytes]:
        answers = []
        for request in requests:
            raw.write(request)
            answers.append(raw.read(12))
        return answers

    raw.timeout = 0.05
    bare = run(bare_read, lambda: raw.write(frames))
    sequential = run(group.read_states, lambda: group.command(commands))
    wire_sequential = (command_bytes + len(ids) * (6 + 12)) * WIRE_BITS / 1e6 + len(ids) * response
    slot = group.stagger()
    broadcast = run(group.read_states_broadcast, lambda: group.command(commands))
    wire_broadcast = (command_bytes + 6) * WIRE_BITS / 1e6 + len(ids) * slot * 100e-6 + 12 * WIRE_BITS / 1e6
    bus.close()
    endpoint.stop()
    sim.close()
    return {
        "bare_pyserial_cycles_per_s": round(bare, 1),
        "library_vs_bare": round(sequential / bare, 3),
        "sequential_cycles_per_s": round(sequential, 1),
        "sequential_wire_max_per_s": round(1 / wire_sequential, 1),
        "sequential_fraction_of_wire": round(sequential * wire_sequential, 3),
        "broadcast_cycles_per_s": round(broadcast, 1),
        "broadcast_wire_max_per_s": round(1 / wire_broadcast, 1),
        "broadcast_fraction_of_wire": round(broadcast * wire_broadcast, 3),
        "stagger_slot_us": slot * 100,
    }


def main() -> None:
    quick = "--quick" in sys.argv
    results = {
        "latency": latency(200 if quick else 2000),
        "discovery": discovery(),
        "control_cycle_8_motors_1Mbps": control_cycle(1.0 if quick else 5.0),
    }
    print(json.dumps(results, indent=2))
    if not quick:
        record = {
            "results": results,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "date": time.strftime("%Y-%m-%d"),
            "transport": "pseudo-terminal to the simulator",
        }
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
