"""What participants and endpoints announce (SPDP's DATA(p), SEDP's DATA(w)/DATA(r)), built and read.

Besides what every DDS sends, our endpoints carry PID_PARTICIPANT_GUID: Fast DDS 3 (ROS 2 Kilted)
attributes an endpoint to its participant, and so to a ROS node, only through that parameter
(docs/ros2.md, "The node graph").
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from . import wire
from .wire import Guid, Locator

# builtin endpoint set: participant, publications and subscriptions announcers and detectors
BUILTIN_ENDPOINTS = 0x3F
RELIABLE, BEST_EFFORT = 2, 1
VOLATILE, TRANSIENT_LOCAL = 0, 1
KEEP_LAST, KEEP_ALL = 0, 1
STATUS_DISPOSED_UNREGISTERED = b"\x00\x00\x00\x03"


@dataclass(frozen=True)
class Qos:
    reliable: bool = True
    transient_local: bool = False
    depth: int = 10

    def params(self) -> list[bytes]:
        blocking = struct.pack("<iI", 0, int(0.1 * 2**32))  # 100 ms, as ROS 2's default profile
        return [
            wire.param(wire.PID_RELIABILITY, struct.pack("<I", RELIABLE if self.reliable else BEST_EFFORT) + blocking),
            wire.param(wire.PID_DURABILITY, struct.pack("<I", TRANSIENT_LOCAL if self.transient_local else VOLATILE)),
            wire.param(wire.PID_HISTORY, struct.pack("<Ii", KEEP_LAST, self.depth)),
        ]


@dataclass
class RemoteParticipant:
    guid_prefix: bytes
    vendor: tuple[int, int]
    metatraffic: list[Locator]
    default: list[Locator]
    lease: float
    last_seen: float = 0.0


@dataclass
class RemoteEndpoint:
    guid: Guid
    topic: str
    type_name: str
    reliable: bool
    transient_local: bool
    locators: list[Locator] = field(default_factory=list)
    vendor: tuple[int, int] = (0, 0)


def _duration(value: bytes, little: bool) -> float:
    sec, frac = struct.unpack_from("<iI" if little else ">iI", value)
    if sec == 0x7FFFFFFF:
        return float("inf")
    return float(sec + frac / 2**32)


def _payload_params(payload: bytes) -> tuple[list[tuple[int, bytes]], bool]:
    if len(payload) < 4 or payload[0] != 0 or payload[1] not in (2, 3):
        raise wire.WireError("discovery data that is not a parameter list (PL_CDR)")
    little = payload[1] == 3
    params, _ = wire.parse_params(payload, 4, little)
    return params, little


def _locators(params: list[tuple[int, bytes]], pid: int, little: bool) -> list[Locator]:
    out = []
    for p, value in params:
        if p == pid:
            locator = Locator.unpack(value, little)
            if locator.kind == wire.LOCATOR_UDPV4:
                out.append(locator)
    return out


def is_dispose(item: wire.Data) -> bool:
    return any(pid == wire.PID_STATUS_INFO and value[3:4] != b"\x00" for pid, value in item.inline_qos)


def key_guid(item: wire.Data) -> Guid | None:
    for pid, value in item.inline_qos:
        if pid == wire.PID_KEY_HASH and len(value) >= 16:
            return Guid.from_raw(value[:16])
    return None


# -- participants -----------------------------------------------------------------------------


def participant_data(
    prefix: bytes, metatraffic: list[Locator], default: list[Locator], lease: float, user_data: bytes, name: str
) -> bytes:
    params = [
        wire.param(wire.PID_PROTOCOL_VERSION, bytes(wire.VERSION)),
        wire.param(wire.PID_VENDORID, bytes(wire.VENDOR)),
        wire.param(wire.PID_PARTICIPANT_GUID, prefix + wire.ENTITY_PARTICIPANT),
        wire.param(wire.PID_BUILTIN_ENDPOINT_SET, struct.pack("<I", BUILTIN_ENDPOINTS)),
        *(wire.param(wire.PID_METATRAFFIC_UNICAST_LOCATOR, loc.pack()) for loc in metatraffic),
        *(wire.param(wire.PID_DEFAULT_UNICAST_LOCATOR, loc.pack()) for loc in default),
        wire.param(wire.PID_PARTICIPANT_LEASE_DURATION, struct.pack("<iI", int(lease), 0)),
        wire.param_octets(wire.PID_USER_DATA, user_data),
        wire.param_string(wire.PID_ENTITY_NAME, name),
    ]
    return wire.ENCAPSULATION_PL_CDR_LE + wire.param_list(*params)


def parse_participant(item: wire.Data, vendor: tuple[int, int]) -> RemoteParticipant | None:
    """The participant a DATA(p) announces, or None for a dispose (it left)."""
    if item.payload is None or is_dispose(item):
        return None
    params, little = _payload_params(item.payload)
    guid = next((v for p, v in params if p == wire.PID_PARTICIPANT_GUID), None)
    if guid is None or len(guid) < 16:
        raise wire.WireError("a participant announcement without its GUID")
    lease = next((_duration(v, little) for p, v in params if p == wire.PID_PARTICIPANT_LEASE_DURATION), 100.0)
    vendor = next(((v[0], v[1]) for p, v in params if p == wire.PID_VENDORID and len(v) >= 2), vendor)
    return RemoteParticipant(
        guid_prefix=bytes(guid[:12]),
        vendor=vendor,
        metatraffic=_locators(params, wire.PID_METATRAFFIC_UNICAST_LOCATOR, little),
        default=_locators(params, wire.PID_DEFAULT_UNICAST_LOCATOR, little),
        lease=lease,
    )


def participant_dispose(prefix: bytes) -> bytes:
    """The inline QoS of the DATA that says our participant is gone (peers forget it at once)."""
    return wire.param_list(
        wire.param(wire.PID_KEY_HASH, prefix + wire.ENTITY_PARTICIPANT),
        wire.param(wire.PID_STATUS_INFO, STATUS_DISPOSED_UNREGISTERED),
    )


# -- endpoints --------------------------------------------------------------------------------


def endpoint_data(guid: Guid, topic: str, type_name: str, qos: Qos, user_data: bytes, unicast: list[Locator]) -> bytes:
    params = [
        wire.param(wire.PID_ENDPOINT_GUID, guid.raw),
        wire.param(wire.PID_PARTICIPANT_GUID, guid.prefix + wire.ENTITY_PARTICIPANT),
        wire.param_string(wire.PID_TOPIC_NAME, topic),
        wire.param_string(wire.PID_TYPE_NAME, type_name),
        *qos.params(),
        *(wire.param(wire.PID_UNICAST_LOCATOR, loc.pack()) for loc in unicast),
        wire.param(wire.PID_PROTOCOL_VERSION, bytes(wire.VERSION)),
        wire.param(wire.PID_VENDORID, bytes(wire.VENDOR)),
        wire.param(wire.PID_DATA_REPRESENTATION, struct.pack("<Ih", 1, 0)),  # XCDR1, as ROS 2 writes
    ]
    if user_data:
        params.append(wire.param_octets(wire.PID_USER_DATA, user_data))
    return wire.ENCAPSULATION_PL_CDR_LE + wire.param_list(*params)


def endpoint_dispose(guid: Guid) -> bytes:
    return wire.param_list(
        wire.param(wire.PID_KEY_HASH, guid.raw),
        wire.param(wire.PID_STATUS_INFO, STATUS_DISPOSED_UNREGISTERED),
    )


def parse_endpoint(item: wire.Data, participant: RemoteParticipant | None, writer: bool) -> RemoteEndpoint | None:
    """The reader or writer a DATA(r)/DATA(w) announces, or None for a dispose. A QoS left out is
    the default (DDS 1.4, 2.2.3): a writer is reliable, a reader best effort."""
    if item.payload is None or is_dispose(item):
        return None
    params, little = _payload_params(item.payload)
    raw = next((v for p, v in params if p == wire.PID_ENDPOINT_GUID), None)
    if raw is None or len(raw) < 16:
        raise wire.WireError("an endpoint announcement without its GUID")
    topic = type_name = ""
    reliable, transient = writer, False
    for pid, value in params:
        if pid == wire.PID_TOPIC_NAME:
            topic = wire.read_string(value, little)
        elif pid == wire.PID_TYPE_NAME:
            type_name = wire.read_string(value, little)
        elif pid == wire.PID_RELIABILITY:
            reliable = struct.unpack_from("<I" if little else ">I", value)[0] == RELIABLE
        elif pid == wire.PID_DURABILITY:
            transient = struct.unpack_from("<I" if little else ">I", value)[0] >= TRANSIENT_LOCAL
    locators = _locators(params, wire.PID_UNICAST_LOCATOR, little)
    if not locators and participant is not None:
        locators = list(participant.default)
    return RemoteEndpoint(
        guid=Guid.from_raw(raw[:16]),
        topic=topic,
        type_name=type_name,
        reliable=reliable,
        transient_local=transient,
        locators=locators,
        vendor=participant.vendor if participant is not None else (0, 0),
    )
