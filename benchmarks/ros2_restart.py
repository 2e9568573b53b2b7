#!/usr/bin/env python3
"""The first command after a bridge restart, seen by a real ROS 2 node (rclpy Jazzy and Kilted from
PyPI's wheels, `make ros-envs`), DDS on loopback only.

Each round is the test's (python/tests/ros2/test_rclpy.py, restart_round): a node that outlives the
bridge publishes one position command (0 to pi/4) as soon as a bridge's joint_states arrive, to a
fresh bridge, then to one restarted in the same namespace; the time from its publish until the joint
is there in joint_states. Restarted at once (within the stopped bridge's 10 s lease) and after 12 s
(after it). docs/ros2.md, "Restarts and start-up", has what these figures were before the fix.

Usage: python benchmarks/ros2_restart.py [--rounds N]   (writes benchmarks/results/ros2-restart.json)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import statistics
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "ros2-restart.json"
sys.path.insert(0, str(HERE.parent / "python" / "tests"))
os.environ["CYCLONEDDS_URI"] = (  # loopback only, as the tests
    "<CycloneDDS><Domain Id='any'><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery></Domain></CycloneDDS>"
)
os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(100, 200)))

from ros2.test_rclpy import RELEASES, restart_round  # noqa: E402 - the test's round

PAUSES = {"at_once": 0.0, "after_lease": 12.0}  # s between the first bridge's end and the restart


def summary(rounds: list[dict[str, Any]]) -> dict[str, Any]:
    fresh = [r["reach_s"][0] for r in rounds if r["reach_s"][0] is not None]
    restarted = [r["reach_s"][1] for r in rounds if len(r["reach_s"]) > 1 and r["reach_s"][1] is not None]
    diffs = [r["reach_s"][1] - r["reach_s"][0] for r in rounds if len(r["reach_s"]) > 1 and None not in r["reach_s"]]
    return {
        "rounds": len(rounds),
        "fresh_median_s": round(statistics.median(fresh), 3) if fresh else None,
        "restarted_median_s": round(statistics.median(restarted), 3) if restarted else None,
        "restarted_minus_fresh_max_s": round(max(diffs), 3) if diffs else None,
        "lost_fresh": len(rounds) - len(fresh),
        "lost_restarted": len(rounds) - len(restarted),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="rounds per release and restart (default 5)")
    args = parser.parse_args()
    results: dict[str, Any] = {}
    for release in RELEASES:
        for name, pause in PAUSES.items():
            rounds = []
            for _ in range(args.rounds):
                seen = restart_round(release, pause)
                print(release, name, seen, flush=True)
                rounds.append(seen)
            results[f"{release}_{name}"] = {"summary": summary(rounds), "rounds": rounds}
    load = os.getloadavg()
    RESULTS.write_text(
        json.dumps(
            {
                "results": results,
                "python": platform.python_version(),
                "machine": platform.machine(),
                "cores": os.cpu_count(),
                "load_average_at_end": [round(x, 2) for x in load],
                "note": "a shared 2-core host, busy with other work while this ran",
                "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            },
            indent=1,
        )
        + "\n"
    )
    print(json.dumps({k: v["summary"] for k, v in results.items()}, indent=1))


if __name__ == "__main__":
    main()
