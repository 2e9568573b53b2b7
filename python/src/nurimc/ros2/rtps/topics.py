"""ROS 2 topics, services and the node graph on our RTPS participant: the bridge's DDS, as rmw does it.

The same interface as ros2/dds.py's Cyclone-based `Participant` (writer, reader, other_writers,
endpoints, close), plus what the Cyclone binding cannot do: ROS 2 services (services.py) and
endpoint announcements that Fast DDS 3 attributes to our node (discovery.py). Messages are the
IdlStruct types of msgs.py; their CDR comes from the same serializer.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from ..dds import ENCLAVE_USER_DATA, domain_id
from ..graph import DISCOVERY_TOPIC, Gid, NodeEntitiesInfo, ParticipantEntitiesInfo, node_name
from ..names import dds_topic
from ..qoswatch import warning
from ..typehash import user_data
from . import wire
from .discovery import Qos, RemoteEndpoint
from .endpoints import Reader, Writer
from .netconfig import from_environment
from .participant import WireParticipant
from .services import ServiceServer

ROS_DEFAULT = Qos(reliable=True, transient_local=False, depth=10)
GRAPH_QOS = Qos(reliable=True, transient_local=True, depth=1)
GRAPH_WAIT = 2.0  # s to wait for a writer's node to be announced
MAX_BUFFERED = 256  # samples a reader holds for its callback; older ones go first (keep last)


def _type_user_data(data_type: Any) -> bytes:
    try:
        return user_data(data_type)
    except Exception:  # a type typehash.py cannot describe: announced without its hash
        return b""


class TopicWriter:
    def __init__(self, participant: WireParticipant, writer: Writer, ros_name: str) -> None:
        self._participant, self.endpoint, self.ros_name = participant, writer, ros_name

    @property
    def gid(self) -> bytes:
        return self.endpoint.guid.raw

    def write(self, sample: Any) -> None:
        self._participant.write(self.endpoint, sample.serialize())

    def matched(self) -> int:
        return len(self.endpoint.readers)


class TopicReader:
    """Samples wait here (keep last MAX_BUFFERED) until the callback takes them: `take(N)` as Cyclone's."""

    def __init__(self, data_type: Any, ros_name: str, on_data: Callable[[Any], None] | None) -> None:
        self.data_type, self.ros_name, self._on_data = data_type, ros_name, on_data
        self._samples: deque[Any] = deque(maxlen=MAX_BUFFERED)
        self._lock = threading.Lock()
        self._scheduled = False  # a callback is due (one per batch of samples, as a DDS listener)
        self.endpoint: Reader | None = None

    @property
    def gid(self) -> bytes:
        assert self.endpoint is not None
        return self.endpoint.guid.raw

    def deliver(self, item: wire.Data, remote: RemoteEndpoint) -> Callable[[], None] | None:
        """Decode a sample (on the receive thread); returns the callback to run once the lock is free."""
        try:
            sample = self.data_type.deserialize(item.payload or b"")
        except Exception:
            return None  # bytes that are not this type: a misbehaving peer, dropped
        with self._lock:
            self._samples.append(sample)
            if self._on_data is None or self._scheduled:
                return None  # the callback already due takes this sample too
            self._scheduled = True
        return self._call

    def _call(self) -> None:
        with self._lock:
            self._scheduled = False
        if self._on_data is not None:
            self._on_data(self)

    def take(self, N: int = 1) -> list[Any]:
        with self._lock:
            out = [self._samples.popleft() for _ in range(min(N, len(self._samples)))]
        return out


class RtpsParticipant:
    """One RTPS participant with ROS-named topics and services (ROS 2's default QoS unless said)."""

    def __init__(self, domain: int | None = None, log: Callable[[str], None] | None = None) -> None:
        self.domain = domain_id() if domain is None else domain
        self._log = log or (lambda text: None)
        self.rtps = WireParticipant(from_environment(self.domain), user_data=ENCLAVE_USER_DATA)
        self.rtps.after_receive = self._run_callbacks
        self.rtps.on_incompatible = self._incompatible
        self.endpoints: list[tuple[str, str, TopicWriter | TopicReader]] = []
        self.services: list[ServiceServer] = []
        #: told the ROS name of a reader's topic when a writer with an incompatible QoS is found
        self.on_incompatible_qos: Callable[[str], None] | None = None
        self.incompatible_writers: list[tuple[str, bytes]] = []  # (ROS topic, writer GUID)
        self._graph_reader = TopicReader(ParticipantEntitiesInfo, DISCOVERY_TOPIC, None)
        self._graph_reader.endpoint = self.rtps.create_reader(
            DISCOVERY_TOPIC,
            ParticipantEntitiesInfo.__idl_typename__,
            GRAPH_QOS,
            self._graph_reader_sample,
            _type_user_data(ParticipantEntitiesInfo),
        )
        self._graph_writer = self.rtps.create_writer(
            DISCOVERY_TOPIC,
            ParticipantEntitiesInfo.__idl_typename__,
            GRAPH_QOS,
            _type_user_data(ParticipantEntitiesInfo),
        )
        self._nodes_seen: dict[bytes, ParticipantEntitiesInfo] = {}
        self.rtps.start()

    # -- topics ------------------------------------------------------------------------------
    def writer(self, ros_name: str, data_type: Any, qos: Qos = ROS_DEFAULT) -> TopicWriter:
        type_name = data_type.__idl_typename__
        endpoint = self.rtps.create_writer(dds_topic(ros_name), type_name, qos, _type_user_data(data_type))
        writer = TopicWriter(self.rtps, endpoint, ros_name)
        self.endpoints.append((ros_name, data_type.__idl_typename__, writer))
        return writer

    def reader(
        self, ros_name: str, data_type: Any, on_data: Callable[[Any], None] | None = None, qos: Qos = ROS_DEFAULT
    ) -> TopicReader:
        reader = TopicReader(data_type, ros_name, on_data)
        reader.endpoint = self.rtps.create_reader(
            dds_topic(ros_name), data_type.__idl_typename__, qos, reader.deliver, _type_user_data(data_type)
        )
        self.endpoints.append((ros_name, data_type.__idl_typename__, reader))
        return reader

    def service(self, name: str, request_type: Any, response_type: Any, handler: Callable[[Any], Any]) -> ServiceServer:
        server = ServiceServer(
            self.rtps,
            name,
            request_type,
            response_type,
            handler,
            log=self._log,
            user_data=(_type_user_data(request_type), _type_user_data(response_type)),
        )
        self.services.append(server)
        return server

    def other_writers(self, ros_name: str, data_type: Any, wait: float) -> int:
        """How many writers of other participants publish this topic (after `wait` s of discovery)."""
        time.sleep(wait)
        name, type_name = dds_topic(ros_name), data_type.__idl_typename__
        return sum(
            1
            for r in self.rtps.remote_endpoints()
            if r.topic == name and r.type_name == type_name and not self.rtps.is_remote_reader(r)
        )

    # -- the node graph ----------------------------------------------------------------------
    def announce_node(self, name: str, namespace: str) -> None:
        """ros_discovery_info: one node, `namespace/name`, owns every endpoint here (graph.py says why)."""
        readers = [Gid(list(e.gid)) for _, _, e in self.endpoints if isinstance(e, TopicReader)]
        writers = [Gid(list(e.gid)) for _, _, e in self.endpoints if isinstance(e, TopicWriter)]
        for server in self.services:
            readers.append(Gid(list(server.reader.guid.raw)))
            writers.append(Gid(list(server.writer.guid.raw)))
        node = NodeEntitiesInfo(namespace, node_name(name), readers, writers)
        message = ParticipantEntitiesInfo(Gid(list(self.rtps.prefix + wire.ENTITY_PARTICIPANT)), [node])
        self.rtps.write(self._graph_writer, message.serialize())

    def _graph_reader_sample(self, item: wire.Data, remote: RemoteEndpoint) -> Callable[[], None] | None:
        try:
            info = ParticipantEntitiesInfo.deserialize(item.payload or b"")
        except Exception:
            return None
        self._nodes_seen[bytes(info.gid.data)[:12]] = info
        return None

    def node_of(self, writer_guid: bytes) -> str | None:
        """`node /ns/name` that owns a writer, from what ros_discovery_info said."""
        for info in list(self._nodes_seen.values()):
            for node in info.node_entities_info_seq:
                if any(bytes(g.data) == writer_guid for g in node.writer_gid_seq):
                    return f"node {node.node_namespace.rstrip('/')}/{node.node_name}"
        return None

    def wait_for_writers(self) -> None:
        """Nothing to wait for: a sample from a writer not discovered yet is kept and replayed
        (participant.py), where Cyclone DDS loses it (dds.Participant.wait_for_writers)."""

    def node_announcer(self, name: str, namespace: str) -> NodeAnnouncement:
        return NodeAnnouncement(self, node_name(name), namespace)

    def qos_watch(self, log: Callable[[str], None]) -> BestEffortCommandWriters:
        watch = BestEffortCommandWriters(self, log)
        self.on_incompatible_qos = watch.on_incompatible
        return watch

    # -- incompatible QoS --------------------------------------------------------------------
    def _incompatible(self, reader: Reader, remote: RemoteEndpoint) -> None:
        ros_name = next((n for n, _, e in self.endpoints if isinstance(e, TopicReader) and e.endpoint is reader), None)
        if ros_name is None:
            return
        self.incompatible_writers.append((ros_name, remote.guid.raw))
        if self.on_incompatible_qos is not None:
            self.on_incompatible_qos(ros_name)

    def _run_callbacks(self, callbacks: list[Callable[[], None]]) -> None:
        for callback in callbacks:
            try:
                callback()
            except Exception as error:  # a callback's bug must not stop the receive thread
                self._log(f"internal error in a DDS callback: {type(error).__name__}: {error}")

    def close(self) -> None:
        for server in self.services:
            server.close()
        self.endpoints.clear()
        self.rtps.close()


class NodeAnnouncement:
    def __init__(self, participant: RtpsParticipant, name: str, namespace: str) -> None:
        self.participant, self.name, self.namespace = participant, name, namespace

    def announce(self) -> None:
        self.participant.announce_node(self.name, self.namespace)


class BestEffortCommandWriters:
    """Who publishes a command topic best effort (our readers take reliable: no match, nothing moves),
    said once per writer, by node name when ros_discovery_info names it (qoswatch.py's lines)."""

    def __init__(self, participant: RtpsParticipant, log: Callable[[str], None]) -> None:
        self._participant, self._log = participant, log
        self._reported: set[bytes] = set()
        self._lock = threading.Lock()
        self.reported: list[str] = []

    def on_incompatible(self, ros_topic: str) -> None:
        threading.Thread(target=self.check, args=(ros_topic,), name="nurimc-qos-check", daemon=True).start()

    def check(self, ros_topic: str) -> list[str]:
        lines = []
        with self._lock:
            for name, guid in list(self._participant.incompatible_writers):
                if name != ros_topic or guid in self._reported:
                    continue
                self._reported.add(guid)
                deadline = time.monotonic() + GRAPH_WAIT
                who = self._participant.node_of(guid)
                while who is None and time.monotonic() < deadline:
                    time.sleep(0.1)
                    who = self._participant.node_of(guid)
                line = warning(who or f"a DDS participant ({guid[:12].hex()}, not a ROS node)", ros_topic)
                self.reported.append(line)
                lines.append(line)
        for line in lines:
            self._log(line)
        return lines
