"""Our RTPS participant (ros2/rtps/): the wire format, the reliability protocol without sockets, and
two participants (plus Cyclone DDS) on loopback. Real ROS 2 nodes against it: test_rclpy.py."""

from __future__ import annotations

import os
import random
import socket
import struct
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nurimc.ros2 import msgs
from nurimc.ros2.rtps import discovery, wire
from nurimc.ros2.rtps.discovery import Qos, RemoteEndpoint
from nurimc.ros2.rtps.endpoints import Outgoing, Reader, Writer
from nurimc.ros2.rtps.netconfig import from_environment
from nurimc.ros2.rtps.topics import RtpsParticipant
from nurimc.ros2.rtps.wire import Guid, Locator

A, B = b"\x01\xfe" + bytes(10), b"\x01\xfe" + b"\x01" * 10


def wait_for(condition: Callable[[], Any], timeout: float = 10.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.01)
    raise AssertionError(f"not within {timeout} s")


# -- the wire ---------------------------------------------------------------------------------


@given(st.integers(min_value=1, max_value=2**40), st.sets(st.integers(min_value=0, max_value=255), max_size=40))
def test_sequence_number_sets_round_trip(base: int, offsets: set[int]) -> None:
    members = sorted(base + o for o in offsets)
    raw = wire.pack_sn_set(base, members)
    assert wire.unpack_sn_set(raw, 0, True)[:2] == (base, members)


def test_a_participant_announcement_reads_back() -> None:
    loc = Locator.udp4("127.0.0.1", 7410)
    payload = discovery.participant_data(A, [loc], [Locator.udp4("127.0.0.1", 7411)], 20, b"enclave=/;", "x")
    item = wire.Data(wire.ENTITY_UNKNOWN, wire.SPDP_WRITER, 1, [], payload)
    found = discovery.parse_participant(item, wire.VENDOR)
    assert found is not None
    assert (found.guid_prefix, found.metatraffic, found.default[0].port, found.lease) == (A, [loc], 7411, 20)


def test_an_endpoint_announcement_carries_the_participant_guid() -> None:
    """Fast DDS 3 attributes an endpoint to its participant (and ROS node) only by PID_PARTICIPANT_GUID."""
    guid = Guid(A, b"\x00\x00\x01\x03")
    payload = discovery.endpoint_data(guid, "rt/x", "std_msgs::msg::dds_::Bool_", Qos(), b"typehash=x;", [])
    params, _ = wire.parse_params(payload, 4, True)
    assert (wire.PID_PARTICIPANT_GUID, A + wire.ENTITY_PARTICIPANT) in params
    remote = discovery.parse_endpoint(wire.Data(b"", b"", 1, [], payload), None, writer=True)
    assert remote is not None
    assert (remote.guid, remote.topic, remote.reliable, remote.transient_local) == (guid, "rt/x", True, False)


def test_left_out_reliability_is_the_default_of_the_endpoint_kind() -> None:
    """Cyclone DDS leaves out QoS at its default: a writer is then reliable, a reader best effort."""
    payload = wire.ENCAPSULATION_PL_CDR_LE + wire.param_list(
        wire.param(wire.PID_ENDPOINT_GUID, A + b"\x00\x00\x01\x03"), wire.param_string(wire.PID_TOPIC_NAME, "rt/x")
    )
    item = wire.Data(b"", b"", 1, [], payload)
    writer, reader = discovery.parse_endpoint(item, None, True), discovery.parse_endpoint(item, None, False)
    assert writer is not None and reader is not None
    assert (writer.reliable, reader.reliable) == (True, False)


@given(st.binary(max_size=300))
def test_garbage_is_a_wire_error_or_nothing(datagram: bytes) -> None:
    try:
        for sub in wire.parse_message(b"RTPS\x02\x03\x01\x0f" + bytes(12) + datagram)[2]:
            if sub.kind == wire.DATA:
                wire.parse_data(sub)
            elif sub.kind == wire.HEARTBEAT:
                wire.parse_heartbeat(sub)
            elif sub.kind == wire.ACKNACK:
                wire.parse_acknack(sub)
            elif sub.kind == wire.GAP:
                wire.parse_gap(sub)
    except (wire.WireError, struct.error, IndexError):
        pass  # what the receive thread drops; anything else would end it


# -- reliability, without sockets --------------------------------------------------------------


class Link:
    """A writer and a reader joined by a lossy, in-order "network" we step by hand."""

    def __init__(self, reader_durable: bool = False, writer_durable: bool = False) -> None:
        self.delivered: list[bytes] = []
        self.writer = Writer(Guid(A, b"\x00\x00\x01\x03"), "rt/x", "T", Qos(True, writer_durable, 10))
        self.reader = Reader(
            Guid(B, b"\x00\x00\x01\x04"),
            "rt/x",
            "T",
            Qos(True, reader_durable, 10),
            self._deliver,
        )
        self.remote_reader = RemoteEndpoint(self.reader.guid, "rt/x", "T", True, reader_durable, [])
        self.remote_writer = RemoteEndpoint(self.writer.guid, "rt/x", "T", True, writer_durable, [])
        self.drop: set[int] = set()  # sequence numbers whose first DATA is lost

    def _deliver(self, item: wire.Data, remote: RemoteEndpoint) -> None:
        self.delivered.append(item.payload or b"")

    def to_reader(self, out: list[Outgoing]) -> list[Outgoing]:
        back: list[Outgoing] = []
        for item in out:
            for sub in wire.parse_message(wire.header(A) + item.submessages)[2]:
                if sub.kind == wire.DATA:
                    data = wire.parse_data(sub)
                    if data.sn in self.drop:
                        self.drop.discard(data.sn)
                        continue
                    back += self.reader.on_data(self.writer.guid, data)
                elif sub.kind == wire.HEARTBEAT:
                    _, _, first, last, _, final = wire.parse_heartbeat(sub)
                    back += self.reader.on_heartbeat(self.writer.guid, first, last, final)
                elif sub.kind == wire.GAP:
                    self.reader.on_gap(self.writer.guid, wire.parse_gap(sub)[2])
        return back

    def to_writer(self, out: list[Outgoing]) -> list[Outgoing]:
        back: list[Outgoing] = []
        for item in out:
            for sub in wire.parse_message(wire.header(B) + item.submessages)[2]:
                if sub.kind == wire.ACKNACK:
                    _, _, base, missing = wire.parse_acknack(sub)
                    back += self.writer.on_acknack(self.reader.guid, base, missing)
        return back

    def settle(self, out: list[Outgoing]) -> None:
        for _ in range(10):
            out = self.to_writer(self.to_reader(out))
            if not out:
                return


def test_a_lost_sample_is_repaired_and_delivered_in_order() -> None:
    link = Link()
    link.settle(link.writer.match(link.remote_reader) + link.reader.match(link.remote_writer))
    link.drop = {2}
    for n in range(1, 5):
        link.to_writer(link.to_reader(link.writer.write(b"s%03d" % n)))
    assert link.delivered == [b"s001"]  # 3 and 4 wait behind the hole
    link.settle(link.writer.periodic())
    assert link.delivered == [b"s001", b"s002", b"s003", b"s004"]
    assert link.writer.periodic() == []  # all acknowledged: no more heartbeats


def test_a_volatile_reader_gets_nothing_written_before_it_matched() -> None:
    link = Link()
    for n in range(1, 4):
        link.writer.write(b"o%03d" % n)
    link.settle(link.writer.match(link.remote_reader) + link.reader.match(link.remote_writer))
    link.settle(link.writer.write(b"new!"))
    assert link.delivered == [b"new!"]


def test_a_first_sample_from_a_long_lived_writer_is_delivered_at_once() -> None:
    """After a restart the other side's writer is at sequence number N: nothing to wait for (restarts)."""
    link = Link()
    for n in range(1, 50):
        link.writer.write(b"o%03d" % n)
    link.writer.match(link.remote_reader)
    link.reader.match(link.remote_writer)  # no heartbeat exchanged yet
    link.to_reader(link.writer.write(b"1st!"))
    assert link.delivered == [b"1st!"]


def test_a_durable_reader_gets_the_history() -> None:
    link = Link(reader_durable=True, writer_durable=True)
    for n in range(1, 4):
        link.writer.write(b"h%03d" % n)
    link.settle(link.writer.match(link.remote_reader) + link.reader.match(link.remote_writer))
    assert link.delivered == [b"h001", b"h002", b"h003"]


# -- on loopback --------------------------------------------------------------------------------


@pytest.fixture
def loopback(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(100, 200)))


def test_two_participants_exchange_samples_and_forget_each_other_on_close(loopback: None) -> None:
    got: list[Any] = []
    left, right = RtpsParticipant(), RtpsParticipant()
    try:
        writer = left.writer("/t/x", msgs.Float64MultiArray)
        right.reader("/t/x", msgs.Float64MultiArray, lambda r: got.extend(r.take(64)))
        wait_for(lambda: writer.matched())
        for n in range(20):
            writer.write(msgs.Float64MultiArray(data=[float(n)]))
        wait_for(lambda: len(got) == 20)
        assert [s.data[0] for s in got] == [float(n) for n in range(20)]
        assert right.other_writers("/t/x", msgs.Float64MultiArray, 0) == 1
    finally:
        right.close()
    wait_for(lambda: writer.matched() == 0, timeout=5)  # told at once (a dispose), not after the lease
    left.close()


def test_a_cyclone_writer_reaches_our_reader(loopback: None) -> None:
    from nurimc.ros2.dds import Participant

    got: list[Any] = []
    ours = RtpsParticipant()
    cyclone = Participant()
    try:
        ours.reader("/t/cmd", msgs.Float64MultiArray, lambda r: got.extend(r.take(64)))
        writer = cyclone.writer("/t/cmd", msgs.Float64MultiArray)

        def sent() -> bool:
            writer.write(msgs.Float64MultiArray(data=[1.0]))
            return bool(got)

        wait_for(sent)
    finally:
        cyclone.close()
        ours.close()


def test_garbage_datagrams_do_not_stop_the_participant(loopback: None) -> None:
    got: list[Any] = []
    left, right = RtpsParticipant(), RtpsParticipant()
    try:
        writer = left.writer("/t/g", msgs.Bool)
        right.reader("/t/g", msgs.Bool, lambda r: got.extend(r.take(64)))
        wait_for(lambda: writer.matched())
        port = right.rtps.user_locators[0].port
        rng = random.Random(1)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for _ in range(300):
                junk = b"RTPS\x02\x03\x01\x0f" + os.urandom(12) + bytes(rng.randrange(256) for _ in range(40))
                s.sendto(junk, ("127.0.0.1", port))
                s.sendto(os.urandom(64), ("127.0.0.1", port))
        writer.write(msgs.Bool(data=True))
        wait_for(lambda: got)
    finally:
        left.close()
        right.close()


def test_the_interface_and_peers_follow_the_environment() -> None:
    config = from_environment(3, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": "10.1.2.3"})
    assert (config.address, config.multicast, config.peers) == ("127.0.0.1", False, ["127.0.0.1", "10.1.2.3"])
    assert config.meta_unicast_port(1) == 7400 + 250 * 3 + 10 + 2
    user = "<CycloneDDS><Domain><General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    user += "<AllowMulticast>false</AllowMulticast></General></Domain></CycloneDDS>"
    config = from_environment(0, {"CYCLONEDDS_URI": user})
    assert (config.address, config.multicast) == ("127.0.0.1", False)


def test_the_participant_binds_to_the_chosen_interface_only(loopback: None) -> None:
    ours = RtpsParticipant()
    try:
        for s in (ours.rtps._meta, ours.rtps._user):
            assert s.getsockname()[0] == "127.0.0.1"
    finally:
        ours.close()


def test_callbacks_run_without_the_participant_lock(loopback: None) -> None:
    """A reader's callback may write (the bridge answers on another topic) without a deadlock."""
    left, right = RtpsParticipant(), RtpsParticipant()
    done = threading.Event()
    try:
        ping = left.writer("/t/ping", msgs.Bool)
        pong = right.writer("/t/pong", msgs.Bool)

        def answer(reader: Any) -> None:
            for sample in reader.take(8):
                pong.write(sample)

        def answered(reader: Any) -> None:
            if reader.take(8):
                done.set()

        right.reader("/t/ping", msgs.Bool, answer)
        left.reader("/t/pong", msgs.Bool, answered)
        wait_for(lambda: ping.matched() and pong.matched())
        ping.write(msgs.Bool(data=True))
        assert done.wait(10)
    finally:
        left.close()
        right.close()


def test_a_cyclone_dds_client_gets_its_request_header_back(loopback: None) -> None:
    """rmw_cyclonedds_cpp puts (client id, request number) in band, before the request; the reply
    must carry the same 16 bytes (and the Fast DDS form, inline, on every reply: test_rclpy.py)."""
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

    from nurimc.ros2.dds import Participant, default_qos
    from nurimc.ros2.interfaces import Trigger_Request, Trigger_Response

    from .trigger_types import CycloneTriggerRequest, CycloneTriggerResponse

    ours = RtpsParticipant()
    cyclone = Participant()
    try:
        ours.service("/t/trigger", Trigger_Request, Trigger_Response, lambda request: Trigger_Response(True, "done"))
        qos = default_qos()
        request_topic = Topic(cyclone.participant, "rq/t/triggerRequest", CycloneTriggerRequest, qos=qos)
        reply_topic = Topic(cyclone.participant, "rr/t/triggerReply", CycloneTriggerResponse, qos=qos)
        writer = DataWriter(cyclone.participant, request_topic)
        reader = DataReader(cyclone.participant, reply_topic)
        wait_for(lambda: writer.get_matched_subscriptions() and reader.get_matched_publications())
        writer.write(CycloneTriggerRequest(client=0x1234_5678_9ABC_DEF0, number=7))
        replies = wait_for(lambda: reader.take(N=4))
        assert (replies[0].client, replies[0].number, replies[0].success, replies[0].message) == (
            0x1234_5678_9ABC_DEF0,
            7,
            True,
            "done",
        )
    finally:
        cyclone.close()
        ours.close()


def test_a_sample_from_a_writer_not_yet_discovered_is_delivered_once_it_is(loopback: None) -> None:
    """Fast DDS's announcement of a writer often comes after the writer's first sample to us (a
    command sent right after it matched our reader): kept, and delivered when the writer is known."""
    from nurimc.ros2.rtps.netconfig import NetConfig
    from nurimc.ros2.rtps.participant import WireParticipant

    got: list[bytes] = []
    ours = WireParticipant(NetConfig(domain=int(os.environ["ROS_DOMAIN_ID"]), address="127.0.0.1", multicast=False))
    try:

        def take(item: wire.Data, remote: RemoteEndpoint) -> None:
            got.append(item.payload or b"")

        ours.create_reader("rt/x", "T", Qos(), take)
        peer = b"\x01\x0f" + bytes(range(10))  # a Fast DDS participant
        writer = Guid(peer, b"\x00\x00\x12\x03")
        locator = Locator.udp4("127.0.0.1", 9)  # the discard port: what we send back goes nowhere
        sample = b"\x00\x01\x00\x00cmd!"
        ours._receive(wire.header(peer) + wire.data(wire.ENTITY_UNKNOWN, writer.entity, 7, sample))
        assert got == []  # unknown writer: kept, not delivered
        spdp = discovery.participant_data(peer, [locator], [locator], 20, b"", "node")
        ours._receive(wire.header(peer) + wire.data(wire.ENTITY_UNKNOWN, wire.SPDP_WRITER, 1, spdp))
        sedp = discovery.endpoint_data(writer, "rt/x", "T", Qos(), b"", [locator])
        ours._receive(wire.header(peer) + wire.data(wire.SEDP_PUB_READER, wire.SEDP_PUB_WRITER, 1, sedp))
        assert got == [sample]
    finally:
        ours.close()


def test_a_reply_waits_for_the_clients_reply_reader_to_be_discovered(loopback: None) -> None:
    """A client asks as soon as it has matched our request reader, which may be before we know its
    reply reader: the reply waits for that reader (a volatile reply sent before would be lost)."""
    from nurimc.ros2.interfaces import Trigger_Request, Trigger_Response

    ours = RtpsParticipant()
    inbox = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    inbox.bind(("127.0.0.1", 0))
    inbox.settimeout(10)
    try:
        ours.service("/t/later", Trigger_Request, Trigger_Response, lambda request: Trigger_Response(True, "yes"))
        rtps = ours.rtps
        client = b"\x01\x0f" + os.urandom(10)  # a Fast DDS participant
        here = Locator.udp4("127.0.0.1", inbox.getsockname()[1])
        request_writer, reply_reader = Guid(client, b"\x00\x00\x01\x03"), Guid(client, b"\x00\x00\x02\x04")

        def feed(*submessages: bytes) -> None:
            rtps._receive(wire.header(client) + b"".join(submessages))

        feed(
            wire.data(
                wire.ENTITY_UNKNOWN,
                wire.SPDP_WRITER,
                1,
                discovery.participant_data(client, [here], [here], 20, b"", "c"),
            )
        )
        announce = discovery.endpoint_data(
            request_writer, "rq/t/laterRequest", "std_srvs::srv::dds_::Trigger_Request_", Qos(), b"", [here]
        )
        feed(wire.data(wire.SEDP_PUB_READER, wire.SEDP_PUB_WRITER, 1, announce))
        asked = wire.param_list(wire.param(wire.PID_RELATED_SAMPLE_IDENTITY, reply_reader.raw + wire.pack_sn(-1)))
        feed(wire.data(wire.ENTITY_UNKNOWN, request_writer.entity, 1, Trigger_Request().serialize(), asked))
        time.sleep(0.3)  # the request is being answered: the reply reader is announced only now
        announce = discovery.endpoint_data(
            reply_reader, "rr/t/laterReply", "std_srvs::srv::dds_::Trigger_Response_", Qos(), b"", [here]
        )
        feed(wire.data(wire.SEDP_SUB_READER, wire.SEDP_SUB_WRITER, 1, announce))
        deadline = time.monotonic() + 10
        reply = None
        while reply is None and time.monotonic() < deadline:
            datagram = inbox.recv(65536)
            for sub in wire.parse_message(datagram)[2]:
                if sub.kind == wire.DATA and wire.parse_data(sub).reader == reply_reader.entity:
                    reply = wire.parse_data(sub)
        assert reply is not None and reply.payload is not None
        assert Trigger_Response.deserialize(reply.payload).message == "yes"
        identity = dict(reply.inline_qos)[wire.PID_RELATED_SAMPLE_IDENTITY]
        assert identity == reply_reader.raw + wire.pack_sn(1)  # the client's reader, the request's number
    finally:
        inbox.close()
        ours.close()
