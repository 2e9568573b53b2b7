"""DDS set-up as ROS 2 does it: the domain from ROS_DOMAIN_ID, ROS 2's default QoS, topics by ROS name.

ROS 2's default QoS profile (rmw_qos_profile_default) is reliable, volatile, keep last 10; we
use it on every topic, as ROS 2 nodes do for joint_states, command and diagnostics topics.
Which network interfaces and peers DDS uses comes from CYCLONEDDS_URI (Cyclone DDS's own
configuration; the tests pin it to the loopback interface).
"""

from __future__ import annotations

import os
import time
from typing import Any

from cyclonedds.core import Listener, Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from .names import dds_topic

MAX_DOMAIN_ID = 232  # ROS 2's limit with the default port mapping


def domain_id(environ: dict[str, str] | None = None) -> int:
    """ROS_DOMAIN_ID (0 when unset), checked."""
    text = (os.environ if environ is None else environ).get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f"ROS_DOMAIN_ID={text!r}: give a number 0..{MAX_DOMAIN_ID}") from None
    if not 0 <= value <= MAX_DOMAIN_ID:
        raise ValueError(f"ROS_DOMAIN_ID={value}: give a number 0..{MAX_DOMAIN_ID}")
    return value


def default_qos() -> Qos:
    """ROS 2's default: reliable, volatile, keep last 10."""
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )


class Participant:
    """One DDS participant with ROS-named topics; readers and writers use ROS 2's default QoS."""

    def __init__(self, domain: int | None = None) -> None:
        self.domain = domain_id() if domain is None else domain
        self.participant = DomainParticipant(self.domain)
        self._topics: dict[str, Topic[Any]] = {}

    def topic(self, ros_name: str, data_type: type[IdlStruct]) -> Topic[Any]:
        name = dds_topic(ros_name)
        if name not in self._topics:
            self._topics[name] = Topic(self.participant, name, data_type, qos=default_qos())
        return self._topics[name]

    def writer(self, ros_name: str, data_type: type[IdlStruct]) -> DataWriter[Any]:
        return DataWriter(self.participant, self.topic(ros_name, data_type), qos=default_qos())

    def reader(self, ros_name: str, data_type: type[IdlStruct], on_data: Any = None) -> DataReader[Any]:
        listener = Listener(on_data_available=on_data) if on_data is not None else None  # type: ignore[no-untyped-call]
        return DataReader(self.participant, self.topic(ros_name, data_type), qos=default_qos(), listener=listener)

    def other_writers(self, ros_name: str, data_type: type[IdlStruct], wait: float) -> int:
        """How many writers of other participants publish this topic (after `wait` s of discovery)."""
        reader = DataReader(self.participant, self.topic(ros_name, data_type), qos=default_qos())
        time.sleep(wait)
        own = self.participant.guid
        others = 0
        for handle in reader.get_matched_publications():
            endpoint = reader.get_matched_publication_data(handle)
            if endpoint is not None and endpoint.participant_key != own:
                others += 1
        reader.__del__()
        return others

    def close(self) -> None:
        # Deleting the participant deletes its readers, writers and topics (and listeners) with it.
        self._topics.clear()
        self.participant.__del__()
