#!/usr/bin/env python3
"""Does the simulator keep real time, and does a request cost the same with 1 or 254 controllers?

Usage: python benchmarks/sim_realtime.py [--quick] [--write]
1. Polling rate against the bus size: a host polls the controller at ID 0 (request_position,
   answer read before the next request) on buses of 1, 32, 128 and 254 controllers, in
   process (the simulator's own cost) and through a pseudo-terminal at 1,000,000 bps with wire
   timing (what a serial program sees). The buses are polled in turn in short batches (one
   cycle: a batch on every bus), so the machine's load hits every size alike; ratio_to_1 is
   the median over cycles of a size's rate over the one-controller rate in the same cycle
   (robust against a burst of load landing on one batch) and must stay >= 0.9.
   Also the simulator's CPU time per request (fake clock), the cost itself.
2. Physics cost: 32 controllers all in motion, stepped (1 ms physics step) for simulated
   seconds on a fake clock; the wall time per simulated second is the CPU share the
   physics needs (below 1.0 means faster than real time).
3. End to end: the same bus on the real clock, served on a pseudo-terminal with wire
   timing at 1,000,000 bps, while a plain-pyserial host polls all 32 positions round
   robin; records transactions/s, answer latency and whether the physics clock kept up.
Writes benchmarks/results/sim-realtime.json after a full run; a --quick run writes nothing
unless --write is given. Not a test: figures depend on the machine.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import serial

from nurimc.protocol import make
from nurimc.sim import SimBus

RESULTS = Path(__file__).resolve().parent / "results" / "sim-realtime.json"
CONTROLLERS = 32
BUS_SIZES = (1, 32, 128, 254)
ROUNDS = 5
POLL_BAUD = 1_000_000


def _poll_bus(size: int, wire_timing: bool) -> SimBus:
    bus = SimBus(wire_timing=wire_timing, eeprom_time=0.0)
    for i in range(size):
        bus.add_controller(i, POLL_BAUD)
    return bus


def _poll(port: serial.SerialBase, count: int) -> tuple[int, float]:
    """Poll ID 0 `count` times (each answer read before the next request): (answers, seconds)."""
    request = make("request_position", 0).encode()
    answers = 0
    t0 = time.perf_counter()
    for _ in range(count):
        port.write(request)
        if len(port.read(12)) == 12:
            answers += 1
    return answers, time.perf_counter() - t0


def _in_process_ports(stack: contextlib.ExitStack) -> dict[int, serial.SerialBase]:
    ports: dict[int, serial.SerialBase] = {}
    for n in BUS_SIZES:
        bus = _poll_bus(n, wire_timing=False)
        stack.callback(bus.close)
        ports[n] = bus.open_serial(baudrate=POLL_BAUD, timeout=0.5)
    return ports


def _pty_ports(stack: contextlib.ExitStack) -> dict[int, serial.SerialBase]:
    ports: dict[int, serial.SerialBase] = {}
    scratch = stack.enter_context(tempfile.TemporaryDirectory())
    for n in BUS_SIZES:
        bus = _poll_bus(n, wire_timing=True)
        stack.callback(bus.close)
        endpoint = bus.serve_pty(link=os.path.join(scratch, f"tty{n}"))
        stack.callback(endpoint.stop)
        ports[n] = stack.enter_context(serial.Serial(endpoint.path, POLL_BAUD, timeout=0.5))
    return ports


def polling(seconds: float) -> dict[str, dict[str, dict[str, Any]]]:
    """Polling rate per bus size, for each way in. Every size has its own bus, all open at
    once, and the host polls them in turn in short batches, so whatever else the machine does
    hits every size alike; a size's rate is its answers over the time spent on its batches."""
    out: dict[str, dict[str, dict[str, Any]]] = {}
    ways = (("in_process", _in_process_ports, 200), ("pty_1Mbps_wire_timing", _pty_ports, 50))
    for name, open_ports, batch in ways:
        with contextlib.ExitStack() as stack:
            ports = open_ports(stack)
            for port in ports.values():
                _poll(port, 20)  # warm up
            answers = dict.fromkeys(BUS_SIZES, 0)
            spent = dict.fromkeys(BUS_SIZES, 0.0)
            sent = dict.fromkeys(BUS_SIZES, 0)
            cycle_ratios: dict[int, list[float]] = {n: [] for n in BUS_SIZES}
            t0 = time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                cycle = {}
                for n, port in ports.items():
                    got, elapsed = _poll(port, batch)
                    answers[n] += got
                    spent[n] += elapsed
                    sent[n] += batch
                    cycle[n] = got / elapsed
                for n in BUS_SIZES:
                    cycle_ratios[n].append(cycle[n] / cycle[1])
        rate = {n: answers[n] / spent[n] for n in BUS_SIZES}
        out[name] = {
            str(n): {
                "polls_per_s": round(rate[n]),
                "ratio_to_1": round(statistics.median(cycle_ratios[n]), 3),
                "ratio_of_totals": round(rate[n] / rate[1], 3),
                "cycles": len(cycle_ratios[n]),
                "polls": sent[n],
                "missing_answers": sent[n] - answers[n],
            }
            for n in BUS_SIZES
        }
    out["simulator_cpu_per_request"] = request_cost()
    return out


def request_cost(count: int = 5000) -> dict[str, dict[str, Any]]:
    """CPU time the simulator spends on one request and its answer (fake clock, no host, no
    waiting): the per-request cost itself, without the machine's scheduling noise."""
    request = make("request_position", 0).encode()
    best: dict[int, float] = {}
    for n in BUS_SIZES:
        now = [0.0]
        bus = SimBus(clock=lambda now=now: now[0], eeprom_time=0.0)  # type: ignore[misc]
        for i in range(n):
            bus.add_controller(i, POLL_BAUD)
        link = bus.open_link(POLL_BAUD)
        for _ in range(ROUNDS):
            cpu = time.process_time()
            for _ in range(count):
                link.write(request)
                now[0] += 0.001
                if len(link.take()) != 12:
                    raise SystemExit(f"request_cost: no answer with {n} controllers")
            best[n] = min(best.get(n, 1.0), (time.process_time() - cpu) / count)
        bus.close()
    return {str(n): {"us": round(best[n] * 1e6, 2), "ratio_to_1": round(best[1] / best[n], 3)} for n in BUS_SIZES}


def start_motion(bus: SimBus) -> None:
    """Every controller busy: half ramp speed, half go back and forth by position."""
    for c in bus.controllers:
        c.handle(make("set_resolution", c.id, resolution=1000), bus.now())
        if c.id % 2:
            msg = make("accel_speed", c.id, direction=c.id % 4 // 2, speed=500 + 20 * c.id, arrival_time=5)
        else:
            msg = make("position_speed", c.id, direction=0, position=60000, speed=300 + 10 * c.id)
        c.handle(msg, bus.now())
        c.busy_until = -1.0


def physics_cost(seconds: float) -> dict[str, float]:
    now = [0.0]
    bus = SimBus(clock=lambda: now[0], eeprom_time=0.0)
    for i in range(CONTROLLERS):
        bus.add_controller(i, 1_000_000)
    start_motion(bus)
    wall = time.perf_counter()
    cpu = time.process_time()
    while now[0] < seconds:
        now[0] += 0.02
        bus.advance()
    wall = time.perf_counter() - wall
    cpu = time.process_time() - cpu
    moving = sum(1 for c in bus.controllers if not c.servo.static)
    return {
        "simulated_s": seconds,
        "wall_s": round(wall, 3),
        "cpu_per_simulated_s": round(cpu / seconds, 4),
        "real_time_factor": round(seconds / wall, 2),
        "physics_steps_per_s": round(CONTROLLERS * seconds / 0.001 / wall),
        "controllers_still_moving_at_end": moving,
    }


def end_to_end(seconds: float) -> dict[str, float]:
    bus = SimBus(wire_timing=True, eeprom_time=0.0)
    for i in range(CONTROLLERS):
        bus.add_controller(i, 1_000_000)
    start_motion(bus)
    link = os.path.join(tempfile.mkdtemp(), "ttySIM")
    endpoint = bus.serve_pty(link=link)
    latencies: list[float] = []
    missing = 0
    cpu = time.process_time()
    watched = bus.controllers[0]
    servo_start = watched.servo.time
    t0 = time.monotonic()
    try:
        with serial.Serial(link, 1_000_000, timeout=0.1) as port:
            requests = [make("request_position", i).encode() for i in range(CONTROLLERS)]
            n = 0
            while time.monotonic() - t0 < seconds:
                start = time.perf_counter()
                port.write(requests[n % CONTROLLERS])
                answer = port.read(12)
                if len(answer) == 12:
                    latencies.append(time.perf_counter() - start)
                else:
                    missing += 1
                n += 1
        elapsed = time.monotonic() - t0
        cpu = time.process_time() - cpu
        # how far the background physics trails the wall clock (it catches up lazily on any request)
        lag = elapsed - (watched.servo.time - servo_start)
    finally:
        endpoint.stop()
        bus.close()
    wire_s = (6 + 12) * 10 / 1_000_000 + 100e-6
    latencies.sort()
    return {
        "seconds": round(elapsed, 2),
        "transactions": len(latencies),
        "transactions_per_s": round(len(latencies) / elapsed),
        "missing_answers": missing,
        "latency_p50_ms": round(statistics.median(latencies) * 1000, 3),
        "latency_p99_ms": round(latencies[int(len(latencies) * 0.99)] * 1000, 3),
        "wire_minimum_ms": round(wire_s * 1000, 3),
        "process_cpu_share": round(cpu / elapsed, 3),
        "physics_clock_behind_s": round(max(lag, 0.0), 3),
    }


def main() -> None:
    quick = "--quick" in sys.argv
    poll = polling(2.0 if quick else 10.0)
    physics = physics_cost(2.0 if quick else 10.0)
    e2e = end_to_end(2.0 if quick else 10.0)
    worst = min(entry["ratio_to_1"] for way in poll.values() for entry in way.values())
    result = {
        "benchmark": "sim_realtime",
        "polling_one_of_n_controllers": poll,
        "polling_worst_ratio_to_1": worst,
        "polling_ratio_ok": worst >= 0.9,
        "controllers": CONTROLLERS,
        "physics_step_s": 0.001,
        "physics": physics,
        "end_to_end_pty_1Mbps_wire_timing": e2e,
        "keeps_real_time": physics["real_time_factor"] > 1.0 and e2e["missing_answers"] == 0,
        "machine": {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count()},
        "quick": quick,
    }
    print(json.dumps(result, indent=2))
    if quick and "--write" not in sys.argv:
        print(f"quick run: {RESULTS} left as it was (add --write to replace it)")
        return
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
