"""DDS set-up as ROS 2 does it: the domain from ROS_DOMAIN_ID, ROS 2's default QoS, topics by ROS name.

ROS 2's default QoS profile (rmw_qos_profile_default) is reliable, volatile, keep last 10; we
use it on every topic, as ROS 2 nodes do for joint_states, command and diagnostics topics.
Which network interfaces and peers DDS uses comes from CYCLONEDDS_URI (Cyclone DDS's own
configuration; the tests pin it to the loopback interface). To it we add one setting of our own,
FAST_DDS_NAME_MATCHING: Fast DDS 3 (ROS 2 Kilted's default middleware) sends XTypes type
information that Cyclone cannot use, so endpoints of Fast DDS participants are matched by topic and
type name, as ROS 2 itself does (docs/ros2.md, "Kilted and Fast DDS 3").
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

from cyclonedds.core import DDSException, Listener, Policy, Qos
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from .ddsconfig import generated_config
from .handshake import Handshakes
from .names import dds_topic
from .typehash import user_data

MAX_DOMAIN_ID = 232  # ROS 2's limit with the default port mapping
FAST_DDS_VENDOR = "1.15"  # eProsima's RTPS vendor id (01.0f)
#: Match endpoints of Fast DDS participants by topic and type name, ignoring their XTypes type
#: information (Cyclone DDS >= 11.0.1; see docs/ros2.md for why).
FAST_DDS_NAME_MATCHING = (
    "<CycloneDDS><Domain Id='any'><Compatibility>"
    f"<IgnoreTypeInformation>{FAST_DDS_VENDOR}</IgnoreTypeInformation>"
    "</Compatibility></Domain></CycloneDDS>"
)
#: What ROS 2's middleware puts in a participant's USER_DATA: the security enclave ("/" = none)
ENCLAVE_USER_DATA = b"enclave=/;"


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


def domain_config(environ: dict[str, str] | None = None) -> str:
    """Our generated configuration (ddsconfig.py: ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS, kept
    peers, quiet logs), then the user's CYCLONEDDS_URI (files or XML, comma-separated; it overrides
    ours), then our compatibility setting."""
    env = os.environ if environ is None else environ
    user = env.get("CYCLONEDDS_URI", "").strip()
    parts = [generated_config(env), *([user] if user else []), FAST_DDS_NAME_MATCHING]
    return ",".join(parts)


def default_qos() -> Qos:
    """ROS 2's default: reliable, volatile, keep last 10."""
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )


def endpoint_qos(data_type: type[IdlStruct]) -> Qos:
    """ROS 2's default QoS, and the USER_DATA rmw gives a reader or writer: the type's hash."""
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
        Policy.Userdata(user_data(data_type)),
    )


class Participant:
    """One DDS participant with ROS-named topics; readers and writers use ROS 2's default QoS."""

    def __init__(self, domain: int | None = None) -> None:
        self.domain = domain_id() if domain is None else domain
        try:  # a domain of our own, with the user's configuration and our compatibility setting
            self._domain: Domain | None = Domain(self.domain, domain_config())
        except DDSException as error:
            if error.code != DDSException.DDS_RETCODE_PRECONDITION_NOT_MET:
                raise ValueError(
                    "Cyclone DDS refused its configuration: check CYCLONEDDS_URI (Cyclone's own line above says "
                    "what it did not take; the bridge adds Compatibility/IgnoreTypeInformation, cyclonedds >= 11.0.1)"
                ) from None
            self._domain = None  # this process already has the domain (e.g. a test's own participant)
        self.participant = DomainParticipant(self.domain, qos=Qos(Policy.Userdata(ENCLAVE_USER_DATA)))
        #: readers in step at once with writers that published before matching them (handshake.py)
        self.handshakes = Handshakes(self.participant)
        self._topics: dict[str, Topic[Any]] = {}
        #: the ROS endpoints (name, ROS type, reader or writer) for the node graph (graph.py)
        self.endpoints: list[tuple[str, str, DataReader[Any] | DataWriter[Any]]] = []
        #: told the ROS name of a reader's topic when a writer with an incompatible QoS is found
        self.on_incompatible_qos: Callable[[str], None] | None = None

    def topic(self, ros_name: str, data_type: type[IdlStruct]) -> Topic[Any]:
        name = dds_topic(ros_name)
        if name not in self._topics:
            self._topics[name] = Topic(self.participant, name, data_type, qos=default_qos())
        return self._topics[name]

    def writer(self, ros_name: str, data_type: type[IdlStruct]) -> DataWriter[Any]:
        writer = DataWriter(self.participant, self.topic(ros_name, data_type), qos=endpoint_qos(data_type))
        self.endpoints.append((ros_name, data_type.__idl_typename__, writer))
        return writer

    def reader(self, ros_name: str, data_type: type[IdlStruct], on_data: Any = None) -> DataReader[Any]:
        callbacks: dict[str, Any] = {}
        if on_data is not None:
            callbacks["on_data_available"] = on_data
        if self.on_incompatible_qos is not None:  # qoswatch.py: who publishes with a QoS we cannot take
            report = self.on_incompatible_qos
            callbacks["on_requested_incompatible_qos"] = lambda reader, status: report(ros_name)
        qos = endpoint_qos(data_type)
        dds_topic_ = self.topic(ros_name, data_type)
        handshakes = self.handshakes
        callbacks["on_subscription_matched"] = lambda reader, status: handshakes.matched(dds_topic_, qos, status)
        listener = Listener(**callbacks)  # type: ignore[no-untyped-call]
        reader = DataReader(self.participant, dds_topic_, qos=qos, listener=listener)
        self.endpoints.append((ros_name, data_type.__idl_typename__, reader))
        return reader

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

    def wait_for_writers(self) -> None:
        """Until the writers of every Fast DDS participant known have been heard of (at most 2 s;
        handshake.py says why: a command sent before is lost on Cyclone DDS)."""
        self.handshakes.wait_until_heard()

    def qos_watch(self, log: Callable[[str], None]) -> Any:
        """Who publishes our command topics with a QoS our readers cannot take, said once by name (qoswatch.py)."""
        from .qoswatch import IncompatibleWriters

        watch = IncompatibleWriters(self.participant, log)
        self.on_incompatible_qos = watch.on_incompatible
        return watch

    def node_announcer(self, name: str, namespace: str) -> Any:
        """The node in the ROS 2 graph (graph.py): `announce()` once every endpoint exists."""
        from .graph import NodeAnnouncer

        return NodeAnnouncer(self, name, namespace)

    def close(self) -> None:
        # Deleting the participant deletes its readers, writers and topics (and listeners) with it.
        self.handshakes.close()
        self._topics.clear()
        self.endpoints.clear()
        self.participant.__del__()
        if self._domain is not None:
            self._domain.__del__()
