#!/usr/bin/env python3
"""The tuner against simulated plants it was not written for (issue 35), on virtual time.

For each plant (sim/plant.py): `tune(loop="position", goal=..., apply=True)` from the MC
factory gains, then an independent 15° step with the starting gains and one with the chosen
gains (measured here with nurimc.procedures.stepresponse, not by the tuner). Recorded: trials used,
aborted trials, gains, the independent figures before and after, the simulated time the tune
took (what it would take on a motor at 115200 bps, EEPROM busy windows included) and the host's
CPU time for it. Virtual time: the figures do not depend on how busy the host is; the CPU time
does (the host was shared with other work when the committed result was recorded).

Usage: python benchmarks/tune_bench.py [--quick]   (writes benchmarks/results/tune.json)
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

from nurimc import Bus
from nurimc.core.clock import VirtualClock
from nurimc.procedures.stepresponse import ResponseFigures, response_figures
from nurimc.procedures.tuning import GOALS
from nurimc.sim import SimBus
from nurimc.sim.plant import Plant
from nurimc.transport import SerialTransport

OUT = Path(__file__).resolve().parent / "results" / "tune.json"
START = (50, 0, 10)
PLANTS = {
    "default": Plant(),
    "heavier x4": Plant(inertia=4.0),
    "lighter x0.3": Plant(inertia=0.3),
    "friction x5/x3": Plant(coulomb=5.0, viscous=3.0),
    "backlash 1 deg": Plant(backlash=1.0),
    "noise 0.05 deg": Plant(noise=0.05),
    "x2, 10 ms dead time": Plant(inertia=2.0, delay=0.01),
    "x3, backlash 0.3 deg": Plant(inertia=3.0, backlash=0.3),
}


def bus_for(plant: Plant) -> tuple[SimBus, Bus]:
    clock = VirtualClock()
    sim = SimBus(clock=clock, eeprom_time=0.05)
    sim.add_controller(id=1, baud=115200)
    bus = Bus(SerialTransport(sim.open_serial(baudrate=115200), "sim://", latency=0.002), clock=clock)
    bus.motor(1).set("resolution", 1024)
    sim.controllers[0].set_plant(plant)
    return sim, bus


def step(bus: Bus, gains: tuple[int, int, int]) -> ResponseFigures:
    motor = bus.motor(1)
    for name, value in zip(("position-kp", "position-ki", "position-kd"), gains, strict=True):
        motor.set(name, value)
    motor.hold()
    bus.clock.sleep(0.5)
    start = motor.read_state().device_position
    motor.move_to(start + 15.0, rpm=30.0)
    began = bus.clock.now()
    times: list[float] = []
    values: list[float] = []
    while (t := bus.clock.now() - began) < 1.2:
        times.append(t)
        values.append(motor.read_state().device_position)
        bus.clock.sleep(0.005)
    return response_figures(times, values, start, start + 15.0, min_band=0.5)


def run(goal: str, trials: int, plants: dict[str, Plant]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, plant in plants.items():
        sim, bus = bus_for(plant)
        try:
            began_virtual, began_cpu = bus.clock.now(), time.process_time()
            result = bus.motor(1).tune(goal=goal, trials=trials, apply=True)
            tune_seconds = bus.clock.now() - began_virtual
            cpu = time.process_time() - began_cpu
            chosen = result.best.gains if result.best is not None else START
            before, after = step(bus, START), step(bus, chosen)
            out[name] = {
                "plant": plant.describe(),
                "trials": len(result.trials),
                "aborted": sum(1 for t in result.trials if t.aborted),
                "chosen_gains": dict(zip(("kp", "ki", "kd"), chosen, strict=True)),
                "unmet": result.unmet,
                "before": {"overshoot_pct": before.overshoot, "settling_s": before.settling_time},
                "after": {"overshoot_pct": after.overshoot, "settling_s": after.settling_time},
                "less_or_equal_overshoot": after.overshoot <= before.overshoot,
                "no_longer_settling": (
                    after.settling_time is not None
                    and (before.settling_time is None or after.settling_time <= before.settling_time)
                ),
                "simulated_s": round(tune_seconds, 1),
                "host_cpu_s": round(cpu, 2),
            }
            print(f"{goal:13} {name:22} {json.dumps(out[name]['after'])} <- {json.dumps(out[name]['before'])}")
        finally:
            bus.close()
            sim.close()
    return out


def main() -> None:
    quick = "--quick" in sys.argv
    trials = 10 if quick else 24
    plants = dict(list(PLANTS.items())[:3]) if quick else PLANTS
    document = {
        "benchmark": "tune",
        "what": "position-loop tune from the MC factory gains on simulated plants; "
        "independent 15 deg steps before/after",
        "trials_budget": trials,
        "goals": {goal: run(goal, trials, plants) for goal in GOALS},
        "host": {
            "python": platform.python_version(),
            "machine": platform.machine(),
            "cpus": os.cpu_count(),
            "loadavg_1min": round(os.getloadavg()[0], 2),
            "note": "virtual time: the figures and simulated_s do not depend on the host; host_cpu_s does "
            "(recorded on a shared 2-core machine busy with other work)",
        },
    }
    if not quick:
        OUT.write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")
        print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
