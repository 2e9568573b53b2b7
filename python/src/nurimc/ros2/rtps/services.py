"""ROS 2 services on our RTPS participant: a request reader and a reply writer per service, as rmw does.

A service `/ns/node/name` is two DDS topics: `rq/ns/node/nameRequest` and `rr/ns/node/nameReply`,
reliable, volatile, keep last 10 (rmw_qos_profile_services_default). Each reply must say which
request it answers, and the two middlewares ROS 2 ships say it differently:

- Fast DDS (rmw_fastrtps, ROS 2's default): out of band, in the reply's inline QoS
  PID_RELATED_SAMPLE_IDENTITY = (the client's reply reader GUID, which the request carries in the same
  parameter, else the request writer's GUID; the request's sequence number). The client drops replies
  without it — the reason the bridge's Cyclone DDS binding, which cannot set inline QoS, cannot serve
  ROS 2 services.
- Cyclone DDS (rmw_cyclonedds_cpp): in band, 16 bytes before the message (the client's 64-bit id and
  its request number), echoed in the reply.

We write both: the inline parameter on every reply, the in-band header when the client is Cyclone.
Requests are handled one at a time per service on a worker thread (a handler may wait for the bus).
"""

from __future__ import annotations

import contextlib
import queue
import struct
import threading
from collections.abc import Callable
from typing import Any

from . import wire
from .discovery import Qos, RemoteEndpoint
from .participant import WireParticipant

SERVICE_QOS = Qos(reliable=True, transient_local=False, depth=10)
CYCLONE_HEADER = 16
#: s a reply waits for the client's reply reader to be discovered: a client may ask as soon as it
#: has matched us, before we have heard of its reader, and a volatile reply written before the
#: match would never reach it (rmw_fastrtps's servers wait the same way)
REPLY_MATCH_WAIT = 2.0
MAX_QUEUED = 64  # requests waiting per service; more are dropped (the client times out), never queued forever


def request_topic(service: str) -> str:
    return f"rq{service}Request"


def reply_topic(service: str) -> str:
    return f"rr{service}Reply"


def related_identity(item: wire.Data, remote: RemoteEndpoint) -> bytes:
    """The sample identity (GUID + sequence number, 24 bytes) a reply to this request must carry."""
    guid = remote.guid.raw
    for pid, value in item.inline_qos:
        if pid in (wire.PID_RELATED_SAMPLE_IDENTITY, wire.PID_CUSTOM_RELATED_SAMPLE_IDENTITY) and len(value) >= 16:
            if value[:16] != bytes(16):
                guid = bytes(value[:16])
            break
    return guid + wire.pack_sn(item.sn)


class ServiceServer:
    def __init__(
        self,
        participant: WireParticipant,
        name: str,
        request_type: Any,
        response_type: Any,
        handler: Callable[[Any], Any],
        log: Callable[[str], None] | None = None,
        user_data: tuple[bytes, bytes] = (b"", b""),
    ) -> None:
        self.name = name
        self.request_type, self.response_type, self.handler = request_type, response_type, handler
        self._participant = participant
        self._log = log or (lambda text: None)
        self._queue: queue.Queue[tuple[wire.Data, RemoteEndpoint] | None] = queue.Queue(MAX_QUEUED)
        self.served = 0
        self._thread = threading.Thread(target=self._work, name=f"nurimc-service{name}", daemon=True)
        self._thread.start()
        self.writer = participant.create_writer(
            reply_topic(name), response_type.__idl_typename__, SERVICE_QOS, user_data[1]
        )
        self.reader = participant.create_reader(
            request_topic(name), request_type.__idl_typename__, SERVICE_QOS, self._on_request, user_data[0]
        )

    def _on_request(self, item: wire.Data, remote: RemoteEndpoint) -> None:
        try:
            self._queue.put_nowait((item, remote))
        except queue.Full:
            self._log(f"{self.name}: {MAX_QUEUED} requests waiting; one dropped")

    def _work(self) -> None:
        while True:
            job = self._queue.get()
            if job is None:
                return
            item, remote = job
            try:
                self._serve(item, remote)
            except Exception as error:  # a request we cannot read or answer: said, never fatal
                self._log(f"{self.name}: request not answered: {type(error).__name__}: {error}")

    def _serve(self, item: wire.Data, remote: RemoteEndpoint) -> None:
        payload = item.payload or b""
        cyclone = remote.vendor == wire.VENDOR_CYCLONE
        header = b""
        if cyclone:
            header = payload[4 : 4 + CYCLONE_HEADER]
            payload = payload[:4] + payload[4 + CYCLONE_HEADER :]
        request = self.request_type.deserialize(payload)
        response = self.handler(request)
        data: bytes = response.serialize()
        if cyclone:
            data = data[:4] + header + data[4:]
        identity = related_identity(item, remote)
        if not self._participant.wait_for_reader(self.writer, identity[:12], REPLY_MATCH_WAIT):
            self._log(f"{self.name}: the client's reply reader was not discovered within {REPLY_MATCH_WAIT:g} s")
        inline = wire.param_list(
            wire.param(wire.PID_RELATED_SAMPLE_IDENTITY, identity),
            wire.param(wire.PID_CUSTOM_RELATED_SAMPLE_IDENTITY, identity),
        )
        self._participant.write(self.writer, data, inline)
        self.served += 1

    def close(self) -> None:
        with contextlib.suppress(queue.Full):
            self._queue.put_nowait(None)


def unpack_identity(raw: bytes) -> tuple[bytes, int]:
    high, low = struct.unpack("<iI", raw[16:24])
    return raw[:16], (high << 32) | low
