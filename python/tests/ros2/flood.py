"""A runaway ROS node in its own process: position_commands at up to RATE/s for SECONDS.

`python -m tests.ros2.flood NAMESPACE SECONDS RATE` (from python/); prints how many it sent.
Its own process, so the flood does not take the test's interpreter (and its subscriber) with it.
"""

from __future__ import annotations

import math
import sys
import time

from .peer import Peer, command


def main() -> None:
    namespace, seconds, rate = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    peer = Peer()
    writer = peer.publisher(f"{namespace}/position_commands", command([]).__class__)
    time.sleep(0.5)  # discovery
    print("flooding", flush=True)
    sent = 0
    start = time.monotonic()
    while (elapsed := time.monotonic() - start) < seconds:
        value = (sent % 8) * math.pi / 8  # on the simulated encoder's 22.5 degree grid
        writer.write(command([value, -value]))
        sent += 1
        if sent > elapsed * rate:
            time.sleep(0.001)
    print(f"sent {sent} in {time.monotonic() - start:.2f} s", flush=True)
    peer.close()


if __name__ == "__main__":
    main()
