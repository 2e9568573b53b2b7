"""The bridge as a node in the ROS 2 graph: what ROS 2's middleware layer (rmw) announces for a node.

ROS 2 nodes are not DDS entities. An rmw implementation (rmw_fastrtps, rmw_cyclonedds, ...) gives
each process one DDS participant and publishes, on the DDS topic `ros_discovery_info` (no `rt/`
prefix, type `rmw_dds_common/msg/ParticipantEntitiesInfo`, reliable, transient local, keep last 1),
which nodes live in that participant and which of its readers and writers belong to each node.
Every rmw builds its graph (`ros2 node list`, `ros2 topic info -v`, rclpy's
`get_node_names_and_namespaces()`, `get_publishers_info_by_topic()`) by joining that message with
the DDS endpoints it discovers. An endpoint is named by its gid: the 16 bytes of its DDS GUID
(12-byte participant prefix, then the 4-byte entity id), which is what both Fast DDS and Cyclone
DDS based rmw implementations take since ROS 2 Iron (Humble's rmw used 24 bytes, the GUID padded
with zeros). The participant also carries USER_DATA `enclave=/;` (dds.py), as rmw sets it.
"""

# No `from __future__ import annotations`: Cyclone DDS reads the field types at run time.
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from cyclonedds.core import Policy, Qos
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, uint8
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from .names import NameError_

if TYPE_CHECKING:  # to the type checker these fields are the plain values they hold
    sequence = list
    GidBytes = list[int]
    Name = str
else:
    from cyclonedds.idl.types import bounded_str, sequence

    GidBytes = array[uint8, 16]
    Name = bounded_str[256]

DISCOVERY_TOPIC = "ros_discovery_info"
GID_SIZE = 16
NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
MAX_NODE_NAME = 255


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: GidBytes = field(default_factory=lambda: [0] * GID_SIZE)


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: Name = ""
    node_name: Name = ""
    reader_gid_seq: sequence[Gid] = field(default_factory=list)
    writer_gid_seq: sequence[Gid] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    gid: Gid = field(default_factory=Gid)
    node_entities_info_seq: sequence[NodeEntitiesInfo] = field(default_factory=list)


def node_name(text: str) -> str:
    """A ROS 2 node name: letters, digits and '_', not starting with a digit."""
    if not text or len(text) > MAX_NODE_NAME or not NODE_NAME.match(text):
        raise NameError_(
            f"--node-name {text!r}: give letters, digits and '_' (not starting with a digit, "
            f"at most {MAX_NODE_NAME} characters)"
        )
    return text


def gid(entity: Any) -> Gid:
    """The rmw gid of a DDS entity: its GUID's 16 bytes."""
    return Gid(list(entity.guid.bytes))


def discovery_qos() -> Qos:
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(1),
    )


class CycloneEndpoints(Protocol):
    """What the announcer needs of dds.Participant (named here, not imported: dds imports this module)."""

    participant: Any
    endpoints: list[Any]


class NodeAnnouncer:
    """Publishes that one node, `namespace/name`, owns every ROS endpoint of the participant."""

    def __init__(self, participant: CycloneEndpoints, name: str, namespace: str) -> None:
        self.participant = participant
        self.name = node_name(name)
        self.namespace = namespace
        topic = Topic(participant.participant, DISCOVERY_TOPIC, ParticipantEntitiesInfo, qos=discovery_qos())
        self._writer = DataWriter(participant.participant, topic, qos=discovery_qos())

    def message(self) -> ParticipantEntitiesInfo:
        readers: list[Gid] = []
        writers: list[Gid] = []
        for _, _, endpoint in self.participant.endpoints:
            (writers if isinstance(endpoint, DataWriter) else readers).append(gid(endpoint))
        node = NodeEntitiesInfo(self.namespace, self.name, readers, writers)
        return ParticipantEntitiesInfo(gid(self.participant.participant), [node])

    def announce(self) -> None:
        """Publish the current state (again after endpoints were added: it is transient local, keep last 1)."""
        self._writer.write(self.message())
