"""The handshake reader (handshake.py): announced on a topic when a writer matches one of our readers,
gone after its hold; a writer matched later gets one of its own. (Its effect on a Fast DDS writer
is tested with real rclpy nodes in test_rclpy.py: the first command after a restart.)"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

from nurimc.ros2 import handshake, msgs
from nurimc.ros2.dds import Participant
from nurimc.ros2.handshake import Handshakes

from .peer import Float64MultiArray, Peer
from .test_end_to_end import unique


def wait(condition: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {timeout} s")
        time.sleep(0.01)


def readers_of(writer: Any) -> int:
    """How many readers a writer is matched with."""
    return int(writer.get_publication_matched_status().current_count)


def writers_of(reader: Any) -> int:
    return int(reader.get_subscription_matched_status().current_count)


def test_a_matched_writer_sees_a_second_reader_for_a_moment() -> None:
    bridge, peer = Participant(), Peer()
    try:
        bridge.handshakes.close()
        bridge.handshakes = Handshakes(bridge.participant, hold=0.5)
        ns = unique("handshake")
        reader = bridge.reader(f"{ns}/position_commands", msgs.Float64MultiArray)
        writer = peer.publisher(f"{ns}/position_commands", Float64MultiArray)
        wait(lambda: readers_of(writer) == 2, 10, "the writer matched our reader and a handshake reader")
        assert bridge.handshakes.count == 1
        wait(lambda: readers_of(writer) == 1, 10, "the handshake reader deleted after its hold")
        assert writers_of(reader) == 1  # ours stays
        assert bridge.handshakes.count == 1

        # a second writer: a new handshake reader (the first one was announced before it existed)
        second = peer.publisher(f"{ns}/position_commands", Float64MultiArray)
        wait(lambda: readers_of(second) == 2, 10, "a handshake reader for the second writer")
        assert bridge.handshakes.count == 2
        wait(lambda: readers_of(second) == 1, 10, "the second handshake reader deleted")
    finally:
        bridge.close()
        peer.close()


def test_the_start_waits_until_the_writers_of_known_participants_are_heard(monkeypatch: pytest.MonkeyPatch) -> None:
    """wait_until_heard: a participant known without writers holds the start (up to its timeout);
    once one of its writers is heard of, it does not. Fast DDS's GUID prefix stands in for Cyclone's
    here (the test's peers are Cyclone participants)."""
    monkeypatch.setattr(handshake, "FAST_DDS_PREFIX", b"\x01\x10")  # Cyclone's vendor id
    bridge, peer = Participant(), Peer()
    try:
        wait(lambda: peer.participant.guid.bytes.hex() in bridge.handshakes.unheard(), 10, "the peer discovered")
        started = time.monotonic()
        assert not bridge.handshakes.wait_until_heard(0.3)  # no writer of the peer: the whole timeout
        assert time.monotonic() - started >= 0.3
        writer = peer.publisher(unique("heard") + "/estop", Float64MultiArray)
        assert bridge.handshakes.wait_until_heard(10), bridge.handshakes.unheard()
        assert peer.participant.guid.bytes.hex() not in bridge.handshakes.unheard()
        del writer
    finally:
        bridge.close()
        peer.close()
