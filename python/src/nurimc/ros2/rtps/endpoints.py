"""Writers and readers as RTPS's reliability protocol runs them (DDSI-RTPS 2.3, 8.4.9/8.4.12), sans-I/O.

Each method returns what to send (`Outgoing`: submessages for one remote participant's locators);
the participant (participant.py) adds the message header and sends. A writer keeps its last `depth`
samples; a reader delivers each writer's samples in order, once.

Two choices that keep a restart cheap for the other side:
- A reader that matches a writer asks it for a HEARTBEAT at once (an empty ACKNACK), so the writer's
  current range is known within a round trip, not a heartbeat period later.
- A reader's first DATA from a newly matched writer is taken as the start of that writer's stream:
  a volatile reader is owed nothing written before it matched, so there is nothing to wait for.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from . import wire
from .discovery import Qos, RemoteEndpoint
from .wire import Guid, Locator

MAX_NACKED = 256  # a sequence number set's limit


@dataclass
class Outgoing:
    prefix: bytes  # the remote participant (INFO_DST)
    locators: list[Locator]
    submessages: bytes


@dataclass
class ReaderProxy:
    remote: RemoteEndpoint
    start: int  # the first sequence number this reader is owed (volatile: what came after the match)
    acked: int = 0  # everything up to this is acknowledged


class Writer:
    def __init__(self, guid: Guid, topic: str, type_name: str, qos: Qos, user_data: bytes = b"") -> None:
        self.guid, self.topic, self.type_name, self.qos, self.user_data = guid, topic, type_name, qos, user_data
        self.history: dict[int, tuple[bytes, bytes]] = {}  # sn -> (payload, inline QoS)
        self.next_sn = 1
        self.readers: dict[Guid, ReaderProxy] = {}
        self._count = 0

    # the remote readers
    def match(self, remote: RemoteEndpoint) -> list[Outgoing]:
        durable = self.qos.transient_local and remote.transient_local
        start = min(self.history, default=self.next_sn) if durable else self.next_sn
        proxy = ReaderProxy(remote, start, acked=start - 1)
        self.readers[remote.guid] = proxy
        if not remote.reliable:
            return []
        resend = b"".join(self._data(proxy, sn) for sn in sorted(self.history) if sn >= start)
        return [self._to(proxy, resend + self._heartbeat(proxy))]

    def unmatch(self, guid: Guid) -> None:
        self.readers.pop(guid, None)

    # samples
    def write(self, payload: bytes, inline_qos: bytes = b"") -> list[Outgoing]:
        sn = self.next_sn
        self.next_sn += 1
        self.history[sn] = (payload, inline_qos)
        while len(self.history) > self.qos.depth:
            del self.history[min(self.history)]
        # No heartbeat with each sample (it would cost an ACKNACK per sample per reader): the periodic
        # one (participant.HEARTBEAT_PERIOD) repairs a lost sample.
        return [self._to(proxy, self._data(proxy, sn)) for proxy in self.readers.values()]

    def on_acknack(self, reader: Guid, base: int, missing: list[int]) -> list[Outgoing]:
        proxy = self.readers.get(reader)
        if proxy is None:
            return []
        proxy.acked = max(proxy.acked, base - 1)
        subs = b""
        for sn in missing:
            if sn in self.history and sn >= proxy.start:
                subs += self._data(proxy, sn)
            else:  # gone from the history, or written before the reader matched: not for it
                subs += wire.gap(proxy.remote.guid.entity, self.guid.entity, sn, sn + 1)
        if missing or base <= self.next_sn - 1:
            subs += self._heartbeat(proxy, final=not missing)
        return [self._to(proxy, subs)] if subs else []

    def periodic(self) -> list[Outgoing]:
        """A heartbeat to every reliable reader that has not acknowledged everything."""
        if not self.qos.reliable:
            return []
        return [
            self._to(p, self._heartbeat(p))
            for p in self.readers.values()
            if p.remote.reliable and p.acked < self.next_sn - 1
        ]

    # helpers
    def _data(self, proxy: ReaderProxy, sn: int) -> bytes:
        payload, inline = self.history[sn]
        return wire.data(proxy.remote.guid.entity, self.guid.entity, sn, payload, inline)

    def _heartbeat(self, proxy: ReaderProxy, final: bool = False) -> bytes:
        self._count += 1
        first = max(min(self.history, default=self.next_sn), proxy.start)
        last = self.next_sn - 1
        if first > last:
            first = last + 1
        return wire.heartbeat(proxy.remote.guid.entity, self.guid.entity, first, last, self._count, final)

    def _to(self, proxy: ReaderProxy, submessages: bytes) -> Outgoing:
        return Outgoing(proxy.remote.guid.prefix, proxy.remote.locators, submessages)


@dataclass
class WriterProxy:
    remote: RemoteEndpoint
    expected: int = 0  # 0: nothing seen yet
    pending: dict[int, wire.Data | None] = field(default_factory=dict)  # out of order; None = irrelevant


class Reader:
    def __init__(
        self,
        guid: Guid,
        topic: str,
        type_name: str,
        qos: Qos,
        on_sample: Callable[[wire.Data, RemoteEndpoint], Callable[[], None] | None],
        user_data: bytes = b"",
        deferred: list[Callable[[], None]] | None = None,
    ) -> None:
        self.guid, self.topic, self.type_name, self.qos, self.user_data = guid, topic, type_name, qos, user_data
        #: given each sample in order; what it returns runs later, without the participant's lock
        self.on_sample = on_sample
        self.deferred: list[Callable[[], None]] = [] if deferred is None else deferred
        self.writers: dict[Guid, WriterProxy] = {}
        self._count = 0

    def match(self, remote: RemoteEndpoint) -> list[Outgoing]:
        self.writers[remote.guid] = WriterProxy(remote)
        if remote.reliable and self.qos.reliable:  # ask for a heartbeat now (see the module's note)
            # Fast DDS answers an empty ACKNACK at once only when its base is 0 (with 1 it starts its
            # 3 s heartbeat timer); others take 0 as malformed, so they get 1 (docs/ros2.md, "Restarts")
            base = 0 if remote.vendor == wire.VENDOR_FASTDDS else 1
            return [self._acknack(self.writers[remote.guid], base, [], final=False)]
        return []

    def unmatch(self, guid: Guid) -> None:
        self.writers.pop(guid, None)

    def on_data(self, writer: Guid, item: wire.Data) -> list[Outgoing]:
        proxy = self.writers.get(writer)
        if proxy is None:
            return []
        if not (proxy.remote.reliable and self.qos.reliable):  # best effort: newer than the last, or dropped
            if item.sn >= proxy.expected:
                proxy.expected = item.sn + 1
                self._deliver(proxy, item)
            return []
        if proxy.expected == 0:
            proxy.expected = item.sn
        if item.sn < proxy.expected:
            return []
        proxy.pending[item.sn] = item
        self._flush(proxy)
        if proxy.pending:  # a hole before what we hold: ask for it now
            last = max(proxy.pending)
            return [self._acknack(proxy, proxy.expected, self._missing(proxy, last))]
        return []

    def on_heartbeat(self, writer: Guid, first: int, last: int, final: bool) -> list[Outgoing]:
        proxy = self.writers.get(writer)
        if proxy is None or not (proxy.remote.reliable and self.qos.reliable):
            return []
        if proxy.expected == 0:
            proxy.expected = first if self.qos.transient_local else max(first, 1)
        if first > proxy.expected:  # the writer no longer has those: they are lost to us
            for sn in [s for s in proxy.pending if s < first]:
                del proxy.pending[sn]
            proxy.expected = first
            self._flush(proxy)
        missing = self._missing(proxy, last)
        if final and not missing:
            return []
        return [self._acknack(proxy, proxy.expected, missing)]

    def on_gap(self, writer: Guid, irrelevant: list[int]) -> None:
        proxy = self.writers.get(writer)
        if proxy is None:
            return
        if proxy.expected == 0:
            proxy.expected = min(irrelevant, default=1)
        for sn in irrelevant:
            if sn >= proxy.expected:
                proxy.pending.setdefault(sn, None)
        self._flush(proxy)

    def _flush(self, proxy: WriterProxy) -> None:
        while proxy.expected in proxy.pending:
            item = proxy.pending.pop(proxy.expected)
            proxy.expected += 1
            if item is not None:
                self._deliver(proxy, item)

    def _deliver(self, proxy: WriterProxy, item: wire.Data) -> None:
        if item.payload is not None and not item.key_only:
            later = self.on_sample(item, proxy.remote)
            if later is not None:
                self.deferred.append(later)

    def _missing(self, proxy: WriterProxy, last: int) -> list[int]:
        end = min(last, proxy.expected + MAX_NACKED - 1)
        return [sn for sn in range(proxy.expected, end + 1) if sn not in proxy.pending]

    def _acknack(self, proxy: WriterProxy, base: int, missing: list[int], final: bool | None = None) -> Outgoing:
        self._count += 1
        final = not missing if final is None else final
        sub = wire.acknack(self.guid.entity, proxy.remote.guid.entity, base, missing, self._count, final)
        return Outgoing(proxy.remote.guid.prefix, proxy.remote.locators, sub)
