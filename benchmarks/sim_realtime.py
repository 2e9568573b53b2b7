#!/usr/bin/env python3
"""Does the simulator keep real time with 32 controllers on one bus?

Usage: python benchmarks/sim_realtime.py [--quick]
1. Physics cost: 32 controllers all in motion, stepped (1 ms physics step) for simulated
   seconds on a fake clock; the wall time per simulated second is the CPU share the
   physics needs (below 1.0 means faster than real time).
2. End to end: the same bus on the real clock, served on a pseudo-terminal with wire
   timing at 1,000,000 bps, while a plain-pyserial host polls all 32 positions round
   robin; records transactions/s, answer latency and whether the physics clock kept up.
Writes benchmarks/results/sim-realtime.json. Not a test: figures depend on the machine.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import serial

from nurimc.protocol import make
from nurimc.sim import SimBus

RESULTS = Path(__file__).resolve().parent / "results" / "sim-realtime.json"
CONTROLLERS = 32


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
    physics = physics_cost(2.0 if quick else 10.0)
    e2e = end_to_end(2.0 if quick else 10.0)
    result = {
        "benchmark": "sim_realtime",
        "controllers": CONTROLLERS,
        "physics_step_s": 0.001,
        "physics": physics,
        "end_to_end_pty_1Mbps_wire_timing": e2e,
        "keeps_real_time": physics["real_time_factor"] > 1.0 and e2e["missing_answers"] == 0,
        "machine": {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count()},
        "quick": quick,
    }
    print(json.dumps(result, indent=2))
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
