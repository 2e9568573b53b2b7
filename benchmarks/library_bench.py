#!/usr/bin/env python3
"""Benchmarks of the host library against the simulator on a real pseudo-terminal.

1. Transaction latency: the library's request/answer against a bare pyserial write-and-read
   of the same bytes on the same pseudo-terminal, interleaved in one run (goal: ratio <= 1.3).
2. Discovery: 3 controllers at rates unknown to the host, wire timing on (goal: < 15 s).
3. Control cycle: 8 motors at 1 Mbps with wire timing, command all + read all, against the
   wire-limited maximum (goal: >= 0.8 of it); sequential reads and one staggered broadcast read.
4. The cost of a failure: the same broadcast cycle with 3 % of answers missed (each miss
   leaves an answer owed, ruled out by a fence request before that motor is asked again,
   docs/protocol.md "Stale answers"), with the default late-answer bound and a short one;
   and single reads at 1 Mbps: the read after a lost answer against an ordinary read.
   (benchmarks/wire_bench.py measures lost and late answers and discovery against the wire.)
5. Issue 10's "done when", checked from outside with the public API: release() then at once
   move_to/run/hold on `nurimc sim --eeprom-ms 150`; 200 reads with 30 % of answers 60 ms late
   (sim:// URL); 300 broadcast reads of 8 motors at 1 Mbps with 3 % of answers missed.

A missed answer never crashes the benchmark: it is counted (every figure says how many).

Usage: python benchmarks/library_bench.py [--quick]   (writes benchmarks/results/library.json)
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import serial

from nurimc import Bus, Group, MotorState, NurimcError
from nurimc.procedures.discovery import discover
from nurimc.protocol import RequestPosition
from nurimc.sim import FaultConfig, SimBus

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
    missed = {"bare": 0, "library": 0}
    for _ in range(rounds):  # interleaved, so both see the same machine load
        start = time.perf_counter()
        raw_port.write(frame)
        if len(raw_port.read(12)) == 12:
            bare.append(time.perf_counter() - start)
        else:
            missed["bare"] += 1
            raw_port.reset_input_buffer()
        start = time.perf_counter()
        try:
            bus.request(request)
            library.append(time.perf_counter() - start)
        except NurimcError:
            missed["library"] += 1
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
        "missed_bare": missed["bare"],
        "missed_library": missed["library"],
    }


def discovery() -> dict[str, Any]:
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
    complete = sorted((f.id, f.baudrate) for f in found) == sorted(rates.items())
    return {"seconds": round(elapsed, 3), "controllers": len(found), "all_found": complete, "rates_searched": 18}


def cycles(seconds: float, read: Any, command: Any, count: int) -> tuple[float, int, int]:
    """Cycles per second of command + read; a read value that is an error is counted, never fatal.
    Returns (cycles/s, reads that failed, results that were short)."""
    done, failed, short = 0, 0, 0
    start = time.perf_counter()
    end = start + seconds
    while time.perf_counter() < end:
        command()
        states = read()
        short += len(states) != count
        failed += sum(1 for v in (states.values() if isinstance(states, dict) else states) if not _ok(v))
        done += 1
    return done / (time.perf_counter() - start), failed, short


def _ok(value: object) -> bool:
    return isinstance(value, MotorState) or (isinstance(value, bytes) and len(value) == 12)


def eight_motors(faults: FaultConfig | None = None, **options: Any) -> tuple[SimBus, Any, Bus, Group]:
    ids = list(range(1, 9))
    sim = SimBus(wire_timing=True, faults=faults, seed=7)
    for device_id in ids:
        sim.add_controller(id=device_id, baud=1_000_000)
    endpoint = sim.serve_pty()
    bus = Bus.open(endpoint.path, baudrate=1_000_000, **options)
    return sim, endpoint, bus, Group(bus, ids)


def wire_limits(group: Group, slot: int) -> tuple[float, float]:
    """Seconds per cycle the wire needs: (one request per motor, one broadcast request)."""
    count = len(group.motors)
    command_bytes = sum(len(m.make_move_to(10.0, rpm=60).encode()) for m in group.motors)
    response = 100e-6
    sequential = (command_bytes + count * (6 + 12)) * WIRE_BITS / 1e6 + count * response
    broadcast = (command_bytes + 6) * WIRE_BITS / 1e6 + count * slot * 100e-6 + 12 * WIRE_BITS / 1e6
    return sequential, broadcast


def control_cycle(seconds: float) -> dict[str, Any]:
    sim, endpoint, bus, group = eight_motors()
    ids = [m.id for m in group.motors]
    commands = [m.make_move_to(10.0, rpm=60) for m in group.motors]
    frames = b"".join(c.encode() for c in commands)
    requests = [RequestPosition(i).encode() for i in ids]
    raw = bus.transport.port  # type: ignore[attr-defined] # the same open port, driven by bare pyserial calls

    def bare_read() -> list[bytes]:
        answers = []
        for request in requests:
            raw.write(request)
            answers.append(raw.read(12))
        return answers

    raw.timeout = 0.05
    bare, bare_failed, _ = cycles(seconds, bare_read, lambda: raw.write(frames), len(ids))
    sequential, seq_failed, seq_short = cycles(seconds, group.read_states, lambda: group.command(commands), len(ids))
    slot = group.stagger()
    broadcast, bc_failed, bc_short = cycles(
        seconds, group.read_states_broadcast, lambda: group.command(commands), len(ids)
    )
    wire_sequential, wire_broadcast = wire_limits(group, slot)
    quiet_waits = bus.stats.quiet_waits
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
        "failed_reads": {"bare": bare_failed, "sequential": seq_failed, "broadcast": bc_failed},
        "short_results": seq_short + bc_short,
        "quiet_waits": quiet_waits,
    }


def cycle_with_misses(seconds: float, miss_rate: float) -> dict[str, Any]:
    """The broadcast cycle when answers go missing: the quiet period's cost, per late-answer bound."""
    out: dict[str, Any] = {"miss_rate": miss_rate}
    for name, options in (("default_late_answer", {}), ("late_answer_10ms", {"late_answer": 0.01})):
        sim, endpoint, bus, group = eight_motors(FaultConfig(miss_rate=miss_rate), **options)
        commands = [m.make_move_to(10.0, rpm=60) for m in group.motors]
        slot = group.stagger()
        missed_before = sim.faults.counts["missed"]
        send = group.command
        rate, failed, short = cycles(seconds, group.read_states_broadcast, lambda c=commands, f=send: f(c), 8)
        _, wire_broadcast = wire_limits(group, slot)
        out[name] = {
            "late_answer_ms": round(bus.core.late_answer * 1000, 1),
            "broadcast_cycles_per_s": round(rate, 1),
            "broadcast_fraction_of_wire": round(rate * wire_broadcast, 3),
            "answers_missed": sim.faults.counts["missed"] - missed_before,
            "quiet_waits": bus.stats.quiet_waits,
            "failed_reads": failed,
            "short_results": short,
        }
        bus.close()
        endpoint.stop()
        sim.close()
    return out


def quiet_cost(reads: int) -> dict[str, Any]:
    """Single reads at 1 Mbps with 10 % of answers missed: the next read of a motor whose answer
    was lost waits out the quiet period (deadline + late answer bound) before it is sent."""
    sim = SimBus(wire_timing=True, faults=FaultConfig(miss_rate=0.1), seed=5)
    sim.add_controller(id=1, baud=1_000_000)
    endpoint = sim.serve_pty()
    bus = Bus.open(endpoint.path, baudrate=1_000_000, retries=0)
    motor = bus.motor(1)
    plain, after_failure, failed = [], [], 0
    for _ in range(reads):
        quiet_before = bus.stats.quiet_waits
        start = time.perf_counter()
        try:
            motor.read_state()
        except NurimcError:
            failed += 1
            continue
        elapsed = time.perf_counter() - start
        (after_failure if bus.stats.quiet_waits > quiet_before else plain).append(elapsed)
    deadline = bus.core.timing.answer_deadline(6, 12, 1_000_000, None)
    late = bus.core.late_answer
    bus.close()
    endpoint.stop()
    sim.close()
    return {
        "reads": reads,
        "failed": failed,
        "plain_read_median_ms": round(statistics.median(plain) * 1000, 3) if plain else None,
        "read_after_a_lost_answer_median_ms": (
            round(statistics.median(after_failure) * 1000, 2) if after_failure else None
        ),
        "reads_after_a_lost_answer": len(after_failure),
        "bound_ms": round((deadline + late) * 1000, 1),
        "note": "a lost answer costs the next read of that ID up to deadline + late_answer (the quiet period)",
    }


def integrity() -> dict[str, Any]:
    """Issue 10's "done when", from outside: the public API against the simulator."""
    out: dict[str, Any] = {}
    for name, check in (
        ("release_then_motion_eeprom_150ms", lambda: release_then_motion(10)),
        ("late_answers_200_reads", lambda: late_answers(200)),
        ("broadcast_300_reads_3pct_missed", lambda: broadcast_reads(300, 0.03)),
    ):
        try:
            out[name] = check()
        except (NurimcError, OSError) as err:  # reported, never fatal
            out[name] = {"error": f"{type(err).__name__}: {err}"}
    return out


def release_then_motion(rounds: int) -> dict[str, Any]:
    """`nurimc sim --eeprom-ms 150` in its own process; release() then at once move_to, run or hold."""
    link = Path(tempfile.mkdtemp(prefix="nurimc-bench-")) / "bus"
    nurimc = Path(sys.executable).with_name("nurimc")
    sim = subprocess.Popen(
        [str(nurimc), "sim", "--link", str(link), "--ids", "1,", "--eeprom-ms", "150"],
        stdout=subprocess.DEVNULL,
    )
    try:
        for _ in range(200):
            if link.exists():
                break
            time.sleep(0.05)
        bus = Bus.open(str(link), baudrate=9600)
        motor = bus.motor(1)
        motor.set("resolution", 1000)
        works = {"move_to": 0, "run": 0, "hold": 0}
        failed: list[str] = []
        for k in range(rounds):
            target = 40.0 + 20 * (k % 3)
            for what in works:
                try:
                    motor.release()
                    if what == "move_to":
                        motor.move_to(target, rpm=600)
                        ok = _reaches(motor, target)
                    elif what == "run":
                        motor.run(60)
                        ok = _spins(motor)
                    else:
                        motor.hold()
                        ok = motor.get("control") == "on"
                except NurimcError as err:
                    ok = False
                    failed.append(f"{what}: {err}")
                works[what] += ok
        motor.release()
        bus.close()
        every_time = all(v == rounds for v in works.values())
        return {"rounds": rounds, "worked": works, "errors": failed[:3], "every_time": every_time}
    finally:
        sim.terminate()
        sim.wait(5)


def _reaches(motor: Any, target: float) -> bool:
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        if abs(motor.read_state().device_position - target) < 1.0:
            return True
    return False


def _spins(motor: Any) -> bool:
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        if motor.read_speed() > 30:
            return True
    return False


def late_answers(reads: int) -> dict[str, Any]:
    """A turning motor read `reads` times with 30 % of answers 60 ms late: a value is stale if
    it lies outside the true positions just before and just after its own call."""
    bus = Bus.open("sim://?motor=1@115200&delay_ms=60&delay_rate=0.3&seed=3", baudrate=115200)
    sim = bus.transport.port.bus  # type: ignore[attr-defined]
    controller = sim.controllers[0]
    motor = bus.motor(1)
    motor.set("resolution", 1000)
    bus.send(motor.make_run(10))

    def true_angle() -> float:
        with sim.lock:
            controller.advance_to(sim.now())
            return float(controller.logical_angle())

    stale = failed = 0
    for _ in range(reads):
        before = true_angle()
        try:
            state = motor.read_state()
        except NurimcError:
            failed += 1
            continue
        after = true_angle()
        stale += not before - 0.1 <= state.device_position <= after + 0.1
    result = {
        "reads": reads,
        "stale_values": stale,
        "failed_reads": failed,
        "answers_delayed": sim.faults.counts["delayed"],
        "stale_frames_dropped": bus.stats.stale_frames,
    }
    bus.close()
    sim.close()
    return result


def broadcast_reads(reads: int, miss_rate: float) -> dict[str, Any]:
    url = f"sim://?ids=1,2,3,4,5,6,7,8&baud=1000000&miss_rate={miss_rate}&seed=11"
    bus = Bus.open(url, baudrate=1_000_000, busy_window=0.03)
    sim = bus.transport.port.bus  # type: ignore[attr-defined]
    group = Group(bus, list(range(1, 9)))
    group.stagger()
    before = sim.faults.counts["missed"]
    short = errors = 0
    for _ in range(reads):
        states = group.read_states_broadcast()
        short += list(states) != list(range(1, 9))
        errors += sum(1 for v in states.values() if not isinstance(v, MotorState))
    result = {
        "reads": reads,
        "motors": 8,
        "short_results": short,
        "answers_missed": sim.faults.counts["missed"] - before,
        "motors_reported_as_errors": errors,
    }
    bus.close()
    sim.close()
    return result


def main() -> None:
    quick = "--quick" in sys.argv
    sections: dict[str, Any] = {
        "latency": lambda: latency(200 if quick else 2000),
        "discovery": discovery,
        "control_cycle_8_motors_1Mbps": lambda: control_cycle(1.0 if quick else 5.0),
        "control_cycle_3pct_missed": lambda: cycle_with_misses(1.0 if quick else 5.0, 0.03),
        "quiet_period_after_a_lost_answer": lambda: quiet_cost(200 if quick else 1000),
        "integrity_issue_10": integrity,
    }
    results: dict[str, Any] = {}
    for name, section in sections.items():
        try:
            results[name] = section()
        except (NurimcError, OSError) as err:  # a section that fails is reported, the others still run
            results[name] = {"error": f"{type(err).__name__}: {err}"}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    print(json.dumps(results, indent=2))
    if not quick:
        record = {
            "results": results,
            "python": platform.python_version(),
            "machine": platform.machine(),
            "date": time.strftime("%Y-%m-%d"),
            "transport": "pseudo-terminal to the simulator",
            "load_average_1min_at_end": load,
            "cpus": os.cpu_count(),
        }
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
