"""A small RTPS participant: discovery (SPDP, SEDP), reliable and best-effort writers and readers, on UDP.

One receive thread runs the protocol (participant.py holds the only lock); writes come from any
thread. Callbacks given to readers run on the receive thread under that lock: they must only queue
(services.py hands requests to a worker of its own).
"""

from __future__ import annotations

import os
import select
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from functools import partial

from . import discovery, wire
from .discovery import Qos, RemoteEndpoint, RemoteParticipant
from .endpoints import Outgoing, Reader, Writer
from .netconfig import MULTICAST_GROUP, NetConfig, local_addresses
from .wire import Guid, Locator

SPDP_PERIOD = 1.0  # as the bridge's Cyclone configuration (ddsconfig.SPDP_INTERVAL)
HEARTBEAT_PERIOD = 0.2
LEASE = 20.0
TICK = 0.05
MAX_DATAGRAM = 65536
RECV_BATCH = 64  # datagrams taken from a socket per wake-up
UNKNOWN_KEEP = 2.0  # s a not-yet-discovered writer's submessages are kept for replay
UNKNOWN_PER_WRITER = 16
UNKNOWN_WRITERS = 64


def _call_each(calls: list[Callable[[], None]]) -> None:
    for call in calls:
        call()


class NoPortFree(OSError):
    pass


class WireParticipant:
    def __init__(self, config: NetConfig, name: str = "nurimc", user_data: bytes = b"enclave=/;") -> None:
        self.config = config
        self.prefix = bytes(wire.VENDOR) + os.urandom(10)
        self.name = name
        self.user_data = user_data
        self._lock = threading.RLock()
        self._closed = threading.Event()
        self._next_key = 1
        self.index, self._meta, self._user = self._bind()
        self._multicast = self._bind_multicast() if config.multicast else None
        addresses = [config.address] if config.address else local_addresses()
        self.meta_locators = [Locator.udp4(a, config.meta_unicast_port(self.index)) for a in addresses]
        self.user_locators = [Locator.udp4(a, config.user_unicast_port(self.index)) for a in addresses]
        self.remote: dict[bytes, RemoteParticipant] = {}
        self.writers: dict[bytes, Writer] = {}  # by entity id
        self.readers: dict[bytes, Reader] = {}
        self._remote_endpoints: dict[Guid, RemoteEndpoint] = {}
        self._spdp_sn = 0
        self._unknown: dict[Guid, deque[tuple[float, wire.Submessage]]] = {}  # writers not discovered yet
        self._deferred: list[Callable[[], None]] = []  # reader callbacks, run after the lock is released
        #: runs the deferred callbacks (topics.py gives one that logs a callback's error)
        self.after_receive: Callable[[list[Callable[[], None]]], None] = _call_each
        #: told (reader, remote writer) when a writer of a reader's topic offers less than it needs
        self.on_incompatible: Callable[[Reader, RemoteEndpoint], None] | None = None
        self._builtin()
        self._thread = threading.Thread(target=self._run, name="nurimc-rtps", daemon=True)
        self._started = False

    # -- set-up ------------------------------------------------------------------------------
    def _bind(self) -> tuple[int, socket.socket, socket.socket]:
        host = self.config.address or "0.0.0.0"
        for index in range(self.config.max_index + 1):
            meta = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            user = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                meta.bind((host, self.config.meta_unicast_port(index)))
                user.bind((host, self.config.user_unicast_port(index)))
            except OSError:
                meta.close()
                user.close()
                continue
            for s in (meta, user):
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            if self.config.multicast:
                iface = socket.inet_aton(self.config.address or local_addresses()[0])
                meta.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, iface)
                meta.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
                meta.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 1)
            return index, meta, user
        raise NoPortFree(
            f"no free RTPS port pair on {host} for domain {self.config.domain} "
            f"(participant indices 0..{self.config.max_index} are taken): stop a DDS program or raise "
            "MaxAutoParticipantIndex in CYCLONEDDS_URI"
        )

    def _bind_multicast(self) -> socket.socket | None:
        """The discovery multicast group, joined on the chosen interface or on every one (as Cyclone
        DDS does): a machine without a default route still takes part on its LAN."""
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((MULTICAST_GROUP, self.config.meta_multicast_port))
        except OSError:
            s.close()
            return None
        joined = 0
        for address in [self.config.address] if self.config.address else local_addresses():
            membership = socket.inet_aton(MULTICAST_GROUP) + socket.inet_aton(address)
            try:
                s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
                joined += 1
            except OSError:
                continue  # an interface without multicast
        if not joined:
            s.close()
            return None  # no multicast here: unicast peers still work
        return s

    def _builtin(self) -> None:
        self.sedp_pub_writer = Writer(
            Guid(self.prefix, wire.SEDP_PUB_WRITER), "DCPSPublication", "", Qos(True, True, 1 << 20)
        )
        self.sedp_sub_writer = Writer(
            Guid(self.prefix, wire.SEDP_SUB_WRITER), "DCPSSubscription", "", Qos(True, True, 1 << 20)
        )
        self.sedp_pub_reader = Reader(
            Guid(self.prefix, wire.SEDP_PUB_READER), "DCPSPublication", "", Qos(True, True), self._on_publication
        )
        self.sedp_sub_reader = Reader(
            Guid(self.prefix, wire.SEDP_SUB_READER), "DCPSSubscription", "", Qos(True, True), self._on_subscription
        )
        for builtin in (self.sedp_pub_reader, self.sedp_sub_reader):
            builtin.deferred = self._deferred
        for w in (self.sedp_pub_writer, self.sedp_sub_writer):
            self.writers[w.guid.entity] = w
        for r in (self.sedp_pub_reader, self.sedp_sub_reader):
            self.readers[r.guid.entity] = r

    def start(self) -> None:
        if not self._started:
            self._started = True
            self._thread.start()

    # -- endpoints ---------------------------------------------------------------------------
    def _entity(self, kind: int) -> bytes:
        key = self._next_key
        self._next_key += 1
        return key.to_bytes(3, "big") + bytes([kind])

    def create_writer(self, topic: str, type_name: str, qos: Qos, user_data: bytes = b"") -> Writer:
        with self._lock:
            writer = Writer(Guid(self.prefix, self._entity(wire.KIND_WRITER_NO_KEY)), topic, type_name, qos, user_data)
            self.writers[writer.guid.entity] = writer
            out = self.sedp_pub_writer.write(
                discovery.endpoint_data(writer.guid, topic, type_name, qos, user_data, self.user_locators)
            )
            for remote in self._remote_endpoints.values():
                if self.is_remote_reader(remote) and self._matches(remote, topic, type_name, qos):
                    out += writer.match(remote)
        self._send(out)
        return writer

    def create_reader(
        self,
        topic: str,
        type_name: str,
        qos: Qos,
        on_sample: Callable[[wire.Data, RemoteEndpoint], Callable[[], None] | None],
        user_data: bytes = b"",
    ) -> Reader:
        with self._lock:
            guid = Guid(self.prefix, self._entity(wire.KIND_READER_NO_KEY))
            reader = Reader(guid, topic, type_name, qos, on_sample, user_data, self._deferred)
            self.readers[reader.guid.entity] = reader
            out = self.sedp_sub_writer.write(
                discovery.endpoint_data(reader.guid, topic, type_name, qos, user_data, self.user_locators)
            )
            for remote in self._remote_endpoints.values():
                if not self.is_remote_reader(remote) and self._matches(remote, topic, type_name, qos):
                    out += reader.match(remote)
        self._send(out)
        return reader

    def write(self, writer: Writer, payload: bytes, inline_qos: bytes = b"") -> None:
        with self._lock:
            out = writer.write(payload, inline_qos)
        self._send(out, stamp=True)

    def wait_for_reader(self, writer: Writer, prefix: bytes, timeout: float) -> bool:
        """Until the writer has matched a reader of the participant `prefix` (False after `timeout` s)."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                if any(guid.prefix == prefix for guid in writer.readers):
                    return True
            if time.monotonic() >= deadline or self._closed.is_set():
                return False
            time.sleep(0.005)

    def remote_endpoints(self) -> list[RemoteEndpoint]:
        with self._lock:
            return list(self._remote_endpoints.values())

    @staticmethod
    def is_remote_reader(remote: RemoteEndpoint) -> bool:
        return remote.guid.entity[3] & 0x0F in (0x04, 0x07)

    @staticmethod
    def _matches(remote: RemoteEndpoint, topic: str, type_name: str, qos: Qos) -> bool:
        return remote.topic == topic and remote.type_name == type_name

    # -- sending -----------------------------------------------------------------------------
    def _send(self, out: list[Outgoing], stamp: bool = False) -> None:
        if self._closed.is_set():
            return
        head = wire.header(self.prefix)
        ts = wire.info_ts(time.time()) if stamp else b""
        for item in out:
            if not item.submessages:
                continue
            message = head + wire.info_dst(item.prefix) + ts + item.submessages
            for locator in item.locators:
                try:
                    self._user.sendto(message, (locator.host, locator.port))
                except OSError:
                    continue  # an unreachable locator of a peer: others may work

    def _spdp_targets(self) -> list[tuple[str, int]]:
        targets = []
        if self.config.multicast:
            targets.append((MULTICAST_GROUP, self.config.meta_multicast_port))
        for peer in self.config.peers:
            targets += [(peer, self.config.meta_unicast_port(i)) for i in range(self.config.max_index + 1)]
        for remote in self.remote.values():
            targets += [(loc.host, loc.port) for loc in remote.metatraffic]
        return list(dict.fromkeys(targets))

    def _announce(self, targets: list[tuple[str, int]] | None = None, dispose: bool = False) -> None:
        self._spdp_sn += 1
        if dispose:
            body = wire.data(
                wire.ENTITY_UNKNOWN, wire.SPDP_WRITER, self._spdp_sn, None, discovery.participant_dispose(self.prefix)
            )
        else:
            payload = discovery.participant_data(
                self.prefix, self.meta_locators, self.user_locators, LEASE, self.user_data, self.name
            )
            body = wire.data(wire.ENTITY_UNKNOWN, wire.SPDP_WRITER, self._spdp_sn, payload)
        message = wire.header(self.prefix) + wire.info_ts(time.time()) + body
        for target in targets if targets is not None else self._spdp_targets():
            try:
                self._meta.sendto(message, target)
            except OSError:
                continue

    # -- the receive thread ------------------------------------------------------------------
    def _run(self) -> None:
        sockets = [s for s in (self._meta, self._user, self._multicast) if s is not None]
        next_spdp = next_beat = 0.0
        while not self._closed.is_set():
            try:
                ready, _, _ = select.select(sockets, [], [], TICK)
            except (OSError, ValueError):
                return  # closed under us
            for s in ready:
                # what has arrived, up to RECV_BATCH datagrams, before the readers' callbacks run
                # once: a flood of commands costs one select() and one callback per batch
                for _ in range(RECV_BATCH):
                    try:
                        datagram = s.recv(MAX_DATAGRAM, socket.MSG_DONTWAIT)
                    except OSError:  # nothing more (BlockingIOError), or the socket closed
                        break
                    try:
                        self._receive(datagram, callbacks=False)
                    except (wire.WireError, struct.error, IndexError, UnicodeDecodeError):
                        continue  # garbage or a peer we cannot read: dropped, never fatal
            self._run_deferred()
            now = time.monotonic()
            if now >= next_spdp:
                next_spdp = now + SPDP_PERIOD
                with self._lock:
                    self._announce()
                    self._expire(now)
            if now >= next_beat:
                next_beat = now + HEARTBEAT_PERIOD
                with self._lock:
                    out = [o for w in self.writers.values() for o in w.periodic()]
                self._send(out)

    def _receive(self, datagram: bytes, callbacks: bool = True) -> None:
        """One datagram; the readers' callbacks it makes due run now, or at `_run_deferred()`."""
        vendor, source, subs = wire.parse_message(datagram)
        if source == self.prefix:
            return
        out: list[Outgoing] = []
        with self._lock:
            for sub in subs:
                if sub.destination not in (bytes(12), self.prefix):
                    continue
                out += self._dispatch(sub, vendor)
                remote = self.remote.get(sub.source)
                if remote is not None:
                    remote.last_seen = time.monotonic()
        self._send(out)
        if callbacks:
            self._run_deferred()

    def _run_deferred(self) -> None:
        with self._lock:
            calls, self._deferred[:] = list(self._deferred), []
        if calls:
            self.after_receive(calls)

    def _dispatch(self, sub: wire.Submessage, vendor: tuple[int, int]) -> list[Outgoing]:
        """One submessage (under the lock); what to send back."""
        out: list[Outgoing] = []
        if sub.kind == wire.ACKNACK:
            reader_id, writer_id, base, missing = wire.parse_acknack(sub)
            local = self.writers.get(writer_id)
            return local.on_acknack(Guid(sub.source, reader_id), base, missing) if local is not None else []
        if sub.kind == wire.DATA:
            item = wire.parse_data(sub)
            if item.writer == wire.SPDP_WRITER:
                self._on_participant(item, vendor, sub.source)
                return []
            writer, reader_id = Guid(sub.source, item.writer), item.reader
        elif sub.kind == wire.HEARTBEAT:
            reader_id, writer_id, first, last, _, final = wire.parse_heartbeat(sub)
            writer = Guid(sub.source, writer_id)
        elif sub.kind == wire.GAP:
            reader_id, writer_id, irrelevant, _ = wire.parse_gap(sub)
            writer = Guid(sub.source, writer_id)
        else:
            return []
        readers = self._readers_of(writer, reader_id)
        if not readers:
            self._keep_unknown(writer, sub)
        for reader in readers:
            if sub.kind == wire.DATA:
                out += reader.on_data(writer, item)
            elif sub.kind == wire.HEARTBEAT:
                out += reader.on_heartbeat(writer, first, last, final)
            else:
                reader.on_gap(writer, irrelevant)
        return out

    def _keep_unknown(self, writer: Guid, sub: wire.Submessage) -> None:
        """A writer's DATA, HEARTBEAT or GAP before we know the writer: kept for UNKNOWN_KEEP s and
        replayed when it is discovered. Its one match HEARTBEAT, or a command sent right after it
        matched our reader, commonly comes before its announcement does (docs/ros2.md, "Restarts")."""
        if writer.entity[3] & 0xC0 == 0xC0:  # a builtin endpoint's: nothing to replay
            return
        if writer not in self._unknown and len(self._unknown) >= UNKNOWN_WRITERS:
            return  # a flood of made-up writers: keep what is kept
        kept = self._unknown.setdefault(writer, deque(maxlen=UNKNOWN_PER_WRITER))
        kept.append((time.monotonic(), sub))

    def _replay(self, writer: Guid) -> list[Outgoing]:
        kept = self._unknown.pop(writer, None)
        out: list[Outgoing] = []
        for _, sub in kept or ():
            out += self._dispatch(sub, (0, 0))
        return out

    def _readers_of(self, writer: Guid, reader_id: bytes) -> list[Reader]:
        if reader_id != wire.ENTITY_UNKNOWN:
            reader = self.readers.get(reader_id)
            return [reader] if reader is not None and writer in reader.writers else []
        return [r for r in self.readers.values() if writer in r.writers]

    # -- discovery ---------------------------------------------------------------------------
    def _on_participant(self, item: wire.Data, vendor: tuple[int, int], source: bytes) -> None:
        found = discovery.parse_participant(item, vendor)
        if found is None:  # it left
            self._forget(source)
            return
        if found.guid_prefix == self.prefix:
            return
        known = self.remote.get(found.guid_prefix)
        found.last_seen = time.monotonic()
        self.remote[found.guid_prefix] = found
        if known is not None:
            return
        # new: answer it directly (it may know us only from this), then exchange endpoints
        self._announce([(loc.host, loc.port) for loc in found.metatraffic])
        out: list[Outgoing] = []
        for local, remote_entity in (
            (self.sedp_pub_writer, wire.SEDP_PUB_READER),
            (self.sedp_sub_writer, wire.SEDP_SUB_READER),
        ):
            out += local.match(self._builtin_remote(found, remote_entity))
        for reader, remote_entity in (
            (self.sedp_pub_reader, wire.SEDP_PUB_WRITER),
            (self.sedp_sub_reader, wire.SEDP_SUB_WRITER),
        ):
            out += reader.match(self._builtin_remote(found, remote_entity))
        self._send(out)

    @staticmethod
    def _builtin_remote(found: RemoteParticipant, entity: bytes) -> RemoteEndpoint:
        return RemoteEndpoint(Guid(found.guid_prefix, entity), "", "", True, True, found.metatraffic, found.vendor)

    def _on_publication(self, item: wire.Data, _: RemoteEndpoint) -> None:
        self._on_endpoint(item, writer=True)

    def _on_subscription(self, item: wire.Data, _: RemoteEndpoint) -> None:
        self._on_endpoint(item, writer=False)

    def _on_endpoint(self, item: wire.Data, writer: bool) -> None:
        # called under the lock, from _receive; what it sends goes out at once
        try:
            participant = None
            key = discovery.key_guid(item)
            if key is not None:
                participant = self.remote.get(key.prefix)
            remote = discovery.parse_endpoint(item, participant, writer)
        except (wire.WireError, struct.error):
            return
        if remote is None:
            if key is not None:
                self._unmatch(key)
            return
        if participant is None:
            participant = self.remote.get(remote.guid.prefix)
            if participant is not None:
                remote.vendor = participant.vendor
                if not remote.locators:
                    remote.locators = list(participant.default)
        if remote.guid in self._remote_endpoints:
            return
        self._remote_endpoints[remote.guid] = remote
        out: list[Outgoing] = []
        if writer:
            for reader in list(self.readers.values()):
                if reader.type_name and self._matches(remote, reader.topic, reader.type_name, reader.qos):
                    if remote.reliable or not reader.qos.reliable:
                        out += reader.match(remote)
                    elif self.on_incompatible is not None:  # best effort offered, reliable needed: no match
                        self._deferred.append(partial(self.on_incompatible, reader, remote))
            out += self._replay(remote.guid)
        else:
            for local in list(self.writers.values()):
                compatible = local.qos.reliable or not remote.reliable
                if local.type_name and compatible and self._matches(remote, local.topic, local.type_name, local.qos):
                    out += local.match(remote)
        self._send(out)

    def _unmatch(self, guid: Guid) -> None:
        self._remote_endpoints.pop(guid, None)
        for reader in self.readers.values():
            reader.unmatch(guid)
        for writer in self.writers.values():
            writer.unmatch(guid)

    def _forget(self, prefix: bytes) -> None:
        self.remote.pop(prefix, None)
        for guid in [g for g in self._remote_endpoints if g.prefix == prefix]:
            self._unmatch(guid)
        for entity in (wire.SEDP_PUB_READER, wire.SEDP_SUB_READER, wire.SEDP_PUB_WRITER, wire.SEDP_SUB_WRITER):
            self._unmatch(Guid(prefix, entity))

    def _expire(self, now: float) -> None:
        for writer, kept in list(self._unknown.items()):
            if not kept or now - kept[-1][0] > UNKNOWN_KEEP:
                del self._unknown[writer]
        for prefix, remote in list(self.remote.items()):
            if now - remote.last_seen > remote.lease:
                self._forget(prefix)

    # -- the end -----------------------------------------------------------------------------
    def close(self) -> None:
        """Say goodbye (peers forget us at once, not a lease later) and close the sockets."""
        if self._closed.is_set():
            return
        with self._lock:
            self._announce(dispose=True)
            self._closed.set()
        if self._started:
            self._thread.join(timeout=2)
        for s in (self._meta, self._user, self._multicast):
            if s is not None:
                s.close()
