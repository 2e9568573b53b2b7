"""A command flood (10,000/s) costs no backlog and joint_states keeps its rate (issue #39 item 7).

The bridge runs as its own process on a simulated bus, the flood comes over DDS from a third
process (flood.py), as it would from a runaway ROS node. Commands coalesce (latest wins) and a
reading that is due goes before queued commands, so: joint_states keeps >= 0.8 of its rate, every
message names both joints, and the last command of the flood is carried out at once (a backlog
of tens of thousands of commands would take minutes).
"""

from __future__ import annotations

import math
import subprocess
import sys
import time
from pathlib import Path

from .peer import DiagnosticArray, JointState, Peer, command
from .test_end_to_end import BridgeProcess, near, peer, unique

__all__ = ["peer"]

WINDOW = 3.0  # s over which a rate is counted
FLOOD_RATE = 10_000  # commands/s asked of the sender
PYTHON_DIR = Path(__file__).parents[2]


def rate(states: object, seconds: float) -> tuple[float, list[JointState]]:
    before = len(states.poll())  # type: ignore[attr-defined]
    start = time.monotonic()
    while time.monotonic() - start < seconds:  # a measurement window (the reader keeps the last 10: poll often)
        states.poll()  # type: ignore[attr-defined]
        time.sleep(0.01)
    got: list[JointState] = states.poll()[before:]  # type: ignore[attr-defined]
    return len(got) / (time.monotonic() - start), got


def test_joint_states_keep_their_rate_under_a_command_flood(peer: Peer) -> None:
    ns = unique("flood")
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    diagnostics = peer.subscribe("/diagnostics", DiagnosticArray)
    positions = peer.publisher(f"{ns}/position_commands", command([]).__class__)
    bridge = BridgeProcess(ns, "1,2", "--rate", "30")
    try:
        states.wait_for(lambda s: True, 10, "joint_states")
        healthy, _ = rate(states, WINDOW)
        assert healthy > 10, healthy

        flood = subprocess.Popen(
            [sys.executable, "-m", "tests.ros2.flood", ns, str(WINDOW + 1.0), str(FLOOD_RATE)],
            cwd=PYTHON_DIR,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert flood.stdout is not None
        try:
            assert flood.stdout.readline().strip() == "flooding"
            flooded, messages = rate(states, WINDOW)
            done = flood.stdout.readline()
        finally:
            flood.wait(timeout=30)
        sent, seconds = int(done.split()[1]), float(done.split()[3])
        achieved = sent / seconds
        print(f"joint_states {healthy:.1f}/s healthy, {flooded:.1f}/s under {achieved:.0f} commands/s")
        assert achieved > 1_000, achieved  # a flood, on a busy host too
        assert flooded >= 0.8 * healthy, (flooded, healthy, achieved)
        assert all(m.name == ["motor_1", "motor_2"] for m in messages)

        # no backlog: the flood's last word is obeyed at once
        positions.write(command([math.pi / 2, -math.pi / 2]))
        states.wait_for(
            lambda s: near(s.position[0], math.pi / 2, 0.002) and near(s.position[1], -math.pi / 2, 0.002),
            5,
            "both joints at the last command",
        )
        report = diagnostics.wait_for(
            lambda d: any(s.name.endswith(f"{ns[1:]}: bus") for s in d.status), 3, "our bus diagnostics"
        )
        bus = next(s for s in report.status if s.name.endswith(f"{ns[1:]}: bus"))
        values = {kv.key: kv.value for kv in bus.values}
        assert int(values["coalesced_commands"]) > 0, values
    finally:
        assert bridge.stop() == 0, "".join(bridge.stderr)
