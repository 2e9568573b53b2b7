#!/usr/bin/env python3
"""Speed on an imperfect wire (issue 28), side by side in one run, against the wire's own limits.

1. Group-read cycles, 8 motors at 1 Mbps, wire-timed simulator (`sim://...&wire_timing=1`, the
   real clock): command all + one staggered broadcast read, and command all + one request per
   motor, at 0, 1, 3 and 10 % of answers lost, as a fraction of the wire limit (the bytes of
   one cycle at 1 Mbps plus the motors' response times), with the count of stale values
   (a value outside the true positions before and after its own call: must be 0). The fault
   mixes take turns in 0.25 s slices, so that a load that comes and goes (a shared host) hits
   them all alike. The same on virtual time (no host overhead: what the protocol itself costs).
2. 30 % of answers 60 ms late: broadcast reads and single reads, stale values (must be 0).
3. Discovery of N = 1, 2, 8, 32 controllers all at 9600 bps at unknown IDs, one rate searched
   and all 18, against the wire floor computed from the frame sizes, the rates and the
   documented response times (§8: any setting up to 254 x 100 us = 25.4 ms; these
   controllers keep the default, 1 x 100 us):
   - a rate with none: a broadcast ping plus the wait in which any answer would have started
     (the longest response time a controller may have, plus one character): silence proves
     absence only then;
   - a rate with one controller: the same wait (a second one could still answer), its answer
     meanwhile, and one firmware exchange (the result names the firmware);
   - a rate where several controllers answer together: a broadcast ping until the answers
     begin (they do, garbled), then every ID asked once, each request followed by the
     shortest wait in which an answer would have started (the controllers' response time
     plus one character), plus the rest of each controller's answer (firmware, 7 bytes).
   Every controller found is then asked its product line once (issue 27: `AB` answered names an
   MC; a request of 6 bytes and an answer of 7, plus its response time), in the floor too.
   Discovery must be within 1.5x the floor (goal) while staying live (progress notes).
4. A port that refuses 250000 and 76800 bps: the scan goes on (one note per refused rate).

Usage: python benchmarks/wire_bench.py [--quick]   (writes benchmarks/results/wire.json)
"""

from __future__ import annotations

import errno
import json
import os
import platform
import random
import sys
import termios
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from nurimc import Bus, Group, MotorState, NurimcError
from nurimc.core.clock import VirtualClock
from nurimc.core.timing import MAX_RESPONSE_TIME
from nurimc.procedures.discovery import RateSkipped, discover
from nurimc.procedures.multiturn import WRAP_DEGREES
from nurimc.protocol import BAUD_RATES, DEVICE_DEFAULTS, PositionFeedback, decode
from nurimc.sim import FaultConfig, SimBus
from nurimc.sim.controller import Reply
from nurimc.sim.port import SimSerial
from nurimc.transport import SerialTransport

RESULTS = Path(__file__).resolve().parent / "results" / "wire.json"
BITS = 10  # 8N1
RESPONSE = DEVICE_DEFAULTS["response_time"] * 100e-6  # the documented default response time
MOTORS = list(range(1, 9))
RATE = 1_000_000


def chars(n: int, rate: int) -> float:
    return n * BITS / rate


# -- 1 and 2: group-read cycles ---------------------------------------------------------------
def wire_limits(group: Group, commands: list[Any], slot: int) -> dict[str, float]:
    """Seconds per cycle the wire needs: command all + (one broadcast | one request per motor)."""
    command_bytes = sum(len(c.encode()) for c in commands)
    n = len(group.motors)
    broadcast = chars(command_bytes + 6 + 12, RATE) + n * slot * 100e-6
    sequential = chars(command_bytes + n * (6 + 12), RATE) + sum((k + 1) * slot * 100e-6 for k in range(n))
    return {"broadcast": broadcast, "sequential": sequential}


def unwrapped(reported: float, near: float) -> float:
    """The reported (wrapping, 655.36 deg) position on the turn of the continuous angle `near`."""
    return reported + round((near - reported) / WRAP_DEGREES) * WRAP_DEGREES


def true_angles(sim: SimBus) -> dict[int, float]:
    with sim.lock:
        out = {}
        for c in sim.controllers:
            c.advance_to(sim.now())
            out[c.id] = float(c.logical_angle())
        return out


class CycleRun:
    """8 motors at 1 Mbps on a wire-timed simulator with one fault mix, measured in slices, so
    that several mixes can take turns (a load that comes and goes hits them all alike)."""

    def __init__(self, faults: FaultConfig, virtual: bool) -> None:
        self.clock = VirtualClock() if virtual else None
        self.sim = SimBus(wire_timing=True, seed=7, clock=self.clock, eeprom_time=0.02)
        for i in MOTORS:
            self.sim.add_controller(id=i, baud=RATE)
        self.bus = Bus(
            SerialTransport(self.sim.open_serial(baudrate=RATE), "sim://"), clock=self.clock, busy_window=0.03
        )
        self.group = Group(self.bus, MOTORS)
        slot = self.group.stagger()
        for m in self.group.motors:  # turning, so that every value is tied to the moment it was asked
            m.set("resolution", 1000)
        self.commands = [m.make_run(5 + 3 * m.id) for m in self.group.motors]
        self.bus.send(*self.commands)
        self.sim.fault_config = faults
        self.sim.faults.config = faults
        self.limits = wire_limits(self.group, self.commands, slot)
        self.tally = {name: {"cycles": 0, "seconds": 0.0, "stale": 0, "errors": 0} for name in self.limits}
        # what each controller sent, and when it was asked (bus clock): a value is stale if it
        # was produced for a request older than its own call (cheap enough not to slow the cycle)
        self.produced: dict[tuple[int, int, int, int], float] = {}
        send = self.sim._send

        def record(reply: Reply) -> None:
            answer = decode(reply.frame)
            if isinstance(answer, PositionFeedback):
                key = (answer.id, answer.direction, answer.position, answer.speed)
                self.produced[key] = reply.start - reply.controller.settings.response_time * 100e-6
            send(reply)

        self.sim._send = record  # type: ignore[method-assign]

    def run(self, name: str, seconds: float) -> None:
        read = self.group.read_states_broadcast if name == "broadcast" else self.group.read_states
        tally, now = self.tally[name], self.bus.clock.now
        start = now()
        while now() - start < seconds:
            self.group.command(self.commands)
            asked = self.sim.now()
            states = read()
            for state in states.values():
                if not isinstance(state, MotorState):
                    tally["errors"] += 1
                    continue
                direction = 1 if state.device_position < 0 else 0
                key = (state.id, direction, round(abs(state.device_position) * 100), round(state.speed * 10))
                tally["stale"] += self.produced.get(key, -1.0) < asked  # an older request's answer
            tally["cycles"] += 1
        tally["seconds"] += now() - start

    def result(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, tally in self.tally.items():
            rate = tally["cycles"] / tally["seconds"] if tally["seconds"] else 0.0
            out[name] = {
                "cycles_per_s": round(rate, 1),
                "wire_limit_per_s": round(1 / self.limits[name], 1),
                "fraction_of_wire": round(rate * self.limits[name], 3),
                "stale_values": tally["stale"],
                "slots_without_a_value": tally["errors"],
            }
        out["answers_lost"] = self.sim.faults.counts["missed"]
        out["answers_late"] = self.sim.faults.counts["delayed"]
        out["fences"] = self.bus.stats.fences
        out["quiet_waits"] = self.bus.stats.quiet_waits
        self.bus.close()
        self.sim.close()
        return out


def cycles_side_by_side(mixes: dict[str, FaultConfig], virtual: bool, seconds: float) -> dict[str, Any]:
    """Every mix for `seconds` per read kind, in slices of 0.25 s taken in turn."""
    runs = {key: CycleRun(faults, virtual) for key, faults in mixes.items()}
    slices = max(1, round(seconds / 0.25))
    for _ in range(slices):
        for run in runs.values():
            for name in ("broadcast", "sequential"):
                run.run(name, seconds / slices)
    return {key: run.result() for key, run in runs.items()}


def late_single_reads(reads: int) -> dict[str, Any]:
    """One turning motor at 115200 bps read `reads` times, 30 % of answers 60 ms late."""
    bus = Bus.open("sim://?motor=1@115200&delay_ms=60&delay_rate=0.3&seed=3&wire_timing=1", baudrate=115200)
    sim = bus.transport.port.bus  # type: ignore[attr-defined]
    motor = bus.motor(1)
    motor.set("resolution", 1000)
    bus.send(motor.make_run(10))
    stale = failed = 0
    for _ in range(reads):
        before = true_angles(sim)[1]
        try:
            state = motor.read_state()
        except NurimcError:
            failed += 1
            continue
        after = true_angles(sim)[1]
        stale += not before - 0.1 <= unwrapped(state.device_position, before) <= after + 0.1
    result = {
        "reads": reads,
        "stale_values": stale,
        "failed_reads": failed,
        "answers_late": sim.faults.counts["delayed"],
    }
    bus.close()
    sim.close()
    return result


# -- 3: discovery ------------------------------------------------------------------------------
def floor_of_rate(rate: int, controllers: int) -> float:
    """The wire floor for finding `controllers` at `rate` (module docstring)."""
    silence = chars(6, rate) + max(MAX_RESPONSE_TIME + chars(1, rate), RESPONSE + chars(6, rate) * controllers)
    if controllers == 0:
        return silence
    line_question = controllers * (chars(6 + 7, rate) + RESPONSE)  # each found one's product line (AB -> DB)
    if controllers == 1:
        return silence + chars(6 + 7, rate) + RESPONSE + line_question
    walk = 255 * (chars(6, rate) + RESPONSE + chars(1, rate)) + controllers * chars(7 - 1, rate)
    return chars(6, rate) + RESPONSE + chars(1, rate) + walk + line_question


def discovery(n: int, all_rates: bool, seed: int) -> dict[str, Any]:
    ids = sorted(random.Random(seed).sample(range(255), n))
    sim = SimBus(wire_timing=True, seed=seed)
    for i in ids:
        sim.add_controller(id=i, baud=9600)
    rates = list(BAUD_RATES) if all_rates else [9600]
    bus = Bus(SerialTransport(sim.open_serial(baudrate=115200), "sim://"))
    notes: list[float] = []  # when progress was reported: discovery stays live
    start = time.perf_counter()
    found = bus.run(discover(bus.core, rates), on_note=lambda e: notes.append(time.perf_counter()))
    seconds = time.perf_counter() - start
    floor = sum(floor_of_rate(r, n if r == 9600 else 0) for r in rates)
    gaps = [b - a for a, b in zip([start, *notes], [*notes, start + seconds], strict=True)]
    bus.close()
    sim.close()
    return {
        "controllers": n,
        "rates_searched": len(rates),
        "seconds": round(seconds, 3),
        "wire_floor_s": round(floor, 3),
        "ratio_to_floor": round(seconds / floor, 3),
        "all_found": sorted(f.id for f in found) == ids and all(f.firmware is not None for f in found),
        "longest_silence_between_progress_notes_s": round(max(gaps), 3),
    }


# -- 4: a port that refuses rates --------------------------------------------------------------
class PickyPort(SimSerial):
    """A port whose driver refuses 250000 and 76800 bps (termios EINVAL), as some USB chips do."""

    def _reconfigure_port(self, *args: Any, **kwargs: Any) -> None:
        if int(self.baudrate) in (250000, 76800):
            raise termios.error(errno.EINVAL, "Invalid argument")
        super()._reconfigure_port()


def refused_rates() -> dict[str, Any]:
    sim = SimBus(wire_timing=True)
    sim.add_controller(id=4, baud=9600)
    sim.add_controller(id=6, baud=19200)
    port = PickyPort(None, baudrate=9600, timeout=0.1)
    port.bus, port.port = sim, "sim"
    port.open()
    bus = Bus(SerialTransport(port, "/dev/ttyUSB-picky", latency=0.0))
    notes: list[str] = []
    found = bus.run(
        discover(bus.core), on_note=lambda e: notes.append(e.reason) if isinstance(e, RateSkipped) else None
    )
    bus.close()
    sim.close()
    return {"found": [(f.id, f.baudrate) for f in found], "notes": notes, "scan_went_on": len(found) == 2}


def main() -> None:
    quick = "--quick" in sys.argv
    seconds = 1.0 if quick else 4.0
    sections: dict[str, Callable[[], Any]] = {}
    mixes = {f"{miss:.0%}_lost": FaultConfig(miss_rate=miss) for miss in (0.0, 0.01, 0.03, 0.10)}
    mixes["30%_answers_60ms_late"] = FaultConfig(delay_ms=60, delay_rate=0.3)
    sections["cycles_real_time"] = lambda: cycles_side_by_side(mixes, False, seconds)
    sections["cycles_virtual_time"] = lambda: cycles_side_by_side(mixes, True, seconds)
    sections["late_single_reads_115200"] = lambda: late_single_reads(50 if quick else 200)
    for all_rates in (False, True):
        for n in (1, 2, 8, 32):
            key = f"discovery_{n}_at_9600_{'all_rates' if all_rates else 'one_rate'}"
            sections[key] = lambda n=n, a=all_rates: discovery(n, a, seed=n)
    sections["port_refusing_250000_and_76800"] = refused_rates
    results: dict[str, Any] = {}
    for name, section in sections.items():
        try:
            results[name] = section()
        except (NurimcError, OSError) as err:  # a section that fails is reported, the others still run
            results[name] = {"error": f"{type(err).__name__}: {err}"}
        print(name, json.dumps(results[name]), flush=True)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    if not quick:
        record = {
            "results": results,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "date": time.strftime("%Y-%m-%d"),
            "transport": "in-process simulator (sim://), wire timing on",
            "load_average_1min_at_end": load,
            "cpus": os.cpu_count(),
        }
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
