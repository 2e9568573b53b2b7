"""A ROS node on a laptop that joins late: subscribe to each bridge's joint_states, drive each joint.

`python -m tests.ros2.late_node NS1,NS2` (from python/): prints one JSON line with, per namespace,
the seconds until its first joint_states and whether a position command moved the joint there.
Its DDS configuration comes from the environment (the test gives it multicast off, no peers).
"""

from __future__ import annotations

import json
import math
import sys
import time

from .peer import JointState, Peer, command

FIND_WITHIN = 20.0  # s: the test asks for 5; this only bounds the run


def main() -> None:
    namespaces = sys.argv[1].split(",")
    start = time.monotonic()
    peer = Peer()
    states = {ns: peer.subscribe(f"{ns}/joint_states", JointState) for ns in namespaces}
    writers = {ns: peer.publisher(f"{ns}/position_commands", command([]).__class__) for ns in namespaces}
    found: dict[str, float | None] = dict.fromkeys(namespaces)
    while time.monotonic() - start < FIND_WITHIN and None in found.values():
        for ns, subscription in states.items():
            if found[ns] is None and subscription.poll():
                found[ns] = round(time.monotonic() - start, 2)
        time.sleep(0.02)
    moved: dict[str, bool] = {}
    target = math.pi / 2
    for ns in namespaces:
        moved[ns] = False
        deadline = time.monotonic() + 10
        while found[ns] is not None and time.monotonic() < deadline:
            writers[ns].write(command([target]))  # again until it moves: the first may precede matching
            samples = states[ns].poll()
            if samples and abs(samples[-1].position[0] - target) <= 0.002:
                moved[ns] = True
                break
            time.sleep(0.2)
    print(json.dumps({"found_after_s": found, "moved": moved}), flush=True)
    peer.close()


if __name__ == "__main__":
    main()
