#!/usr/bin/env python3
"""CPU per message of the CDR writers: nurimc.recording.cdr (pure Python, what `record` uses)
against Cyclone DDS's Python serialiser (`IdlStruct.serialize`), for the messages `record` writes.

Each figure is the best of 5 runs of N serialisations (microseconds per message), so a busy
machine inflates it least; the bytes of both writers are checked equal first.

Usage: python benchmarks/cdr_writer.py [--n 20000]   (writes benchmarks/results/cdr-writer.json)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import timeit
from pathlib import Path
from typing import Any

from nurimc.recording import cdr
from nurimc.ros2 import msgs

RESULTS = Path(__file__).parent / "results" / "cdr-writer.json"


def messages() -> dict[str, Any]:
    header = msgs.Header(stamp=msgs.Time(1_764_300_000, 123_456_789), frame_id="base_link")
    return {
        "JointState, 2 joints": msgs.JointState(
            header=header,
            name=["motor_1", "motor_2"],
            position=[1.0, 2.0],
            velocity=[0.1, 0.2],
            effort=[0.3, 0.4],
        ),
        "Frame, 7 bytes": msgs.Frame(header.stamp, "tx", 1, "RequestPing", [0xFF, 0xFE, 1, 2, 0xA0, 0, 0], 0),
        "DiagnosticArray, 2 statuses": msgs.DiagnosticArray(
            header,
            [
                msgs.DiagnosticStatus(0, f"nurimc: motor_{i}", "ok", f"id {i}", [msgs.KeyValue("mode", "position")])
                for i in (1, 2)
            ],
        ),
    }


def best_us(call: Any, n: int) -> float:
    return min(timeit.repeat(call, number=n, repeat=5)) / n * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20000)
    args = parser.parse_args()
    rows = []
    for label, message in messages().items():
        ros_type = msgs.ros_type_of(message)
        assert cdr.serialize(ros_type, message) == message.serialize(), label
        cyclone = best_us(message.serialize, args.n)
        ours = best_us(lambda m=message, t=ros_type: cdr.serialize(t, m), args.n)
        rows.append({"message": label, "cyclonedds_us": round(cyclone, 2), "cdr_py_us": round(ours, 2)})
        print(f"{label}: Cyclone DDS {cyclone:.1f} us, recording/cdr.py {ours:.1f} us")
    result = {
        "what": "CPU per message serialised (best of 5 x N), pure-Python CDR writer vs Cyclone DDS's",
        "n": args.n,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "note": "host busy: 2 cores shared with other jobs while measured (see load_average)",
        "results": rows,
    }
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
