"""Say once, by name, who publishes our command topics with a QoS our readers cannot take.

A node that publishes `position_commands` best effort (e.g. `ros2 topic pub --qos-reliability
best_effort`, or a publisher made with SensorDataQoS) never matches the bridge's reliable reader
(ROS 2's default): DDS drops the pairing silently and nothing moves. Cyclone DDS tells the reader
that an incompatible writer exists, not which one; this module looks the writer up among the
discovered publications (DCPSPublication) and its node among the nodes announced on
`ros_discovery_info` (graph.py), and logs one line per writer:

    warning: node /teleop publishes /arm/position_commands best effort; the bridge takes commands
    reliable (ROS 2's default QoS), so nothing it sends arrives: publish them reliable
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
from cyclonedds.core import Policy
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from .graph import DISCOVERY_TOPIC, ParticipantEntitiesInfo, discovery_qos
from .names import dds_topic

GRAPH_WAIT = 2.0  # s to wait for the writer's node to be announced


def warning(who: str, ros_topic: str) -> str:
    """The line said once per best-effort writer of a command topic (on either DDS stack)."""
    return (
        f"warning: {who} publishes {ros_topic} best effort; the bridge takes commands reliable (ROS 2's default "
        "QoS), so nothing it sends arrives: publish them reliable"
    )


class IncompatibleWriters:
    def __init__(self, participant: Any, log: Callable[[str], None]) -> None:
        self._log = log
        self._publications = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        topic = Topic(participant, DISCOVERY_TOPIC, ParticipantEntitiesInfo, qos=discovery_qos())
        self._graph = DataReader(participant, topic, qos=discovery_qos())
        self._reported: set[bytes] = set()
        self._lock = threading.Lock()
        self.reported: list[str] = []  # the lines logged (for tests and diagnostics)

    def on_incompatible(self, ros_topic: str) -> None:
        """Called (from a DDS thread) when a reader of `ros_topic` met a writer it cannot match;
        the look-up runs on a thread of its own, so the DDS thread is not held."""
        threading.Thread(target=self._check_safely, args=(ros_topic,), name="nurimc-qos-check", daemon=True).start()

    def _check_safely(self, ros_topic: str) -> None:
        try:
            self.check(ros_topic)
        except Exception as error:
            self._log(f"warning: a writer of {ros_topic} has a QoS the bridge cannot take ({error})")

    def check(self, ros_topic: str) -> list[str]:
        name = dds_topic(ros_topic)
        lines = []
        with self._lock:
            for endpoint in self._publications.read(N=1024):
                if getattr(endpoint, "topic_name", None) != name or endpoint.key.bytes in self._reported:
                    continue
                reliability = endpoint.qos[Policy.Reliability] if endpoint.qos is not None else None
                if reliability != Policy.Reliability.BestEffort:
                    continue
                self._reported.add(endpoint.key.bytes)
                line = warning(self._who(endpoint.key.bytes), ros_topic)
                self.reported.append(line)
                lines.append(line)
        for line in lines:
            self._log(line)
        return lines

    def _who(self, guid: bytes) -> str:
        """`node /ns/name` owning that writer, from ros_discovery_info (which may come a moment after
        the writer: looked for up to GRAPH_WAIT s); else the DDS participant."""
        deadline = time.monotonic() + GRAPH_WAIT
        while True:
            name = self._node_of(guid)
            if name is not None:
                return name
            if time.monotonic() >= deadline:
                return f"a DDS participant ({guid[:12].hex()}, not a ROS node)"
            time.sleep(0.1)

    def _node_of(self, guid: bytes) -> str | None:
        for info in self._graph.read(N=1024):
            if not isinstance(info, ParticipantEntitiesInfo):
                continue
            for node in info.node_entities_info_seq:
                if any(bytes(g.data) == guid for g in node.writer_gid_seq):
                    namespace = node.node_namespace.rstrip("/")
                    return f"node {namespace}/{node.node_name}"
        return None
