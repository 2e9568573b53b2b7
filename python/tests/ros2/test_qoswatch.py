"""A node publishing commands best effort (incompatible with our reliable reader) is logged once, by name."""

from __future__ import annotations

import time

import pytest
from cyclonedds.core import Policy, Qos
from cyclonedds.pub import DataWriter

from nurimc.ros2 import msgs
from nurimc.ros2.dds import Participant
from nurimc.ros2.graph import NodeAnnouncer
from nurimc.ros2.qoswatch import IncompatibleWriters


def wait_until(check: object, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if check():  # type: ignore[operator]
            return True
        time.sleep(0.02)
    return False


@pytest.mark.parametrize("stack", ["cyclone", "rtps"])
def test_a_best_effort_command_publisher_is_named_once(stack: str) -> None:
    """On either DDS stack of the bridge: Cyclone DDS's (it says a writer is incompatible, we look it up)
    or ours (ros2/rtps/: discovery tells us the writer, ros_discovery_info its node)."""
    from nurimc.ros2.rtps.topics import RtpsParticipant

    topic = f"/qos_{stack}_{time.monotonic_ns() % 10**6}/position_commands"
    bridge = Participant() if stack == "cyclone" else RtpsParticipant()
    teleop = Participant()
    lines: list[str] = []
    watch = bridge.qos_watch(lines.append)
    try:
        bridge.reader(topic, msgs.Float64MultiArray, lambda reader: reader.take())
        # the other node: announced in the ROS graph, its writer best effort (as SensorDataQoS)
        announcer = NodeAnnouncer(teleop, "teleop", "/robot")
        writer = DataWriter(
            teleop.participant, teleop.topic(topic, msgs.Float64MultiArray), qos=Qos(Policy.Reliability.BestEffort)
        )
        teleop.endpoints.append((topic, "", writer))
        announcer.announce()
        assert wait_until(lambda: lines, 10), "nothing logged"
        assert lines[0].startswith(f"warning: node /robot/teleop publishes {topic} best effort;"), lines
        assert "publish them reliable" in lines[0]
        assert watch.check(topic) == []  # once per writer, however often DDS reports it
        assert len(lines) == 1
    finally:
        teleop.close()
        bridge.close()


def test_a_reliable_publisher_is_not_reported() -> None:
    topic = f"/qos_ok_{time.monotonic_ns() % 10**6}/position_commands"
    bridge, other = Participant(), Participant()
    lines: list[str] = []
    watch = IncompatibleWriters(bridge.participant, lines.append)
    try:
        reader = bridge.reader(topic, msgs.Float64MultiArray)
        other.writer(topic, msgs.Float64MultiArray)
        assert wait_until(lambda: reader.get_matched_publications(), 10)
        assert watch.check(topic) == [] and lines == []
    finally:
        other.close()
        bridge.close()
