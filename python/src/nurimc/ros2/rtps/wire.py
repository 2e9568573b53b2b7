"""RTPS 2.3 on the wire: messages, submessages, parameter lists, GUIDs, locators (OMG DDSI-RTPS 2.3, ch. 8/9).

Plain functions over bytes, no sockets and no clocks. We write little-endian and read either order.
Only what a small participant needs: DATA, HEARTBEAT, ACKNACK, GAP, INFO_TS, INFO_DST (and INFO_SRC
read); fragments (DATA_FRAG) are not reassembled: our peers' requests and discovery data are far below
one datagram.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass, field

PROTOCOL = b"RTPS"
VERSION = (2, 3)
#: Not a vendor id the OMG has assigned to anyone: peers treat it as "another vendor" (standard
#: parameters only), which is what we are.
VENDOR = (0x01, 0xFE)
VENDOR_CYCLONE = (0x01, 0x10)
VENDOR_FASTDDS = (0x01, 0x0F)

# submessage ids
PAD, ACKNACK, HEARTBEAT, GAP, INFO_TS, INFO_SRC, INFO_DST, DATA, DATA_FRAG = (
    0x01,
    0x06,
    0x07,
    0x08,
    0x09,
    0x0C,
    0x0E,
    0x15,
    0x16,
)
FLAG_LE = 0x01

# entity ids (4 bytes; the last is the kind)
ENTITY_UNKNOWN = b"\x00\x00\x00\x00"
ENTITY_PARTICIPANT = b"\x00\x00\x01\xc1"
SPDP_WRITER = b"\x00\x01\x00\xc2"
SPDP_READER = b"\x00\x01\x00\xc7"
SEDP_PUB_WRITER = b"\x00\x00\x03\xc2"
SEDP_PUB_READER = b"\x00\x00\x03\xc7"
SEDP_SUB_WRITER = b"\x00\x00\x04\xc2"
SEDP_SUB_READER = b"\x00\x00\x04\xc7"
KIND_WRITER_NO_KEY = 0x03
KIND_READER_NO_KEY = 0x04

# parameter ids
PID_SENTINEL = 0x0001
PID_PARTICIPANT_LEASE_DURATION = 0x0002
PID_TOPIC_NAME = 0x0005
PID_TYPE_NAME = 0x0007
PID_DOMAIN_ID = 0x000F
PID_RELIABILITY = 0x001A
PID_DURABILITY = 0x001D
PID_USER_DATA = 0x002C
PID_UNICAST_LOCATOR = 0x002F
PID_DEFAULT_UNICAST_LOCATOR = 0x0031
PID_METATRAFFIC_UNICAST_LOCATOR = 0x0032
PID_METATRAFFIC_MULTICAST_LOCATOR = 0x0033
PID_HISTORY = 0x0040
PID_DEFAULT_MULTICAST_LOCATOR = 0x0048
PID_PROTOCOL_VERSION = 0x0015
PID_VENDORID = 0x0016
PID_PARTICIPANT_GUID = 0x0050
PID_ENDPOINT_GUID = 0x005A
PID_BUILTIN_ENDPOINT_SET = 0x0058
PID_ENTITY_NAME = 0x0062
PID_KEY_HASH = 0x0070
PID_STATUS_INFO = 0x0071
PID_DATA_REPRESENTATION = 0x0073
PID_RELATED_SAMPLE_IDENTITY = 0x0083
PID_CUSTOM_RELATED_SAMPLE_IDENTITY = 0x800F  # eProsima's older id for the same thing (Fast DDS reads both)

LOCATOR_UDPV4 = 1
ENCAPSULATION_PL_CDR_LE = b"\x00\x03\x00\x00"
SN_UNKNOWN = -1


class WireError(ValueError):
    """A datagram that is not RTPS or is cut short: dropped, never raised past the receiver."""


@dataclass(frozen=True)
class Guid:
    prefix: bytes  # 12 bytes: the participant
    entity: bytes  # 4 bytes

    @property
    def raw(self) -> bytes:
        return self.prefix + self.entity

    @classmethod
    def from_raw(cls, data: bytes) -> Guid:
        if len(data) != 16:
            raise WireError(f"a GUID is 16 bytes, got {len(data)}")
        return cls(bytes(data[:12]), bytes(data[12:]))

    def __str__(self) -> str:
        return self.raw.hex(".", 4)


GUID_UNKNOWN = Guid(bytes(12), ENTITY_UNKNOWN)


@dataclass(frozen=True)
class Locator:
    kind: int
    port: int
    address: bytes  # 16 bytes; IPv4 in the last 4

    @classmethod
    def udp4(cls, host: str, port: int) -> Locator:
        return cls(LOCATOR_UDPV4, port, bytes(12) + bytes(int(p) for p in host.split(".")))

    @property
    def host(self) -> str:
        return ".".join(str(b) for b in self.address[12:])

    def pack(self) -> bytes:
        return struct.pack("<iI", self.kind, self.port) + self.address

    @classmethod
    def unpack(cls, data: bytes, little: bool = True) -> Locator:
        if len(data) < 24:
            raise WireError("a locator is 24 bytes")
        kind, port = struct.unpack("<iI" if little else ">iI", data[:8])
        return cls(kind, port, bytes(data[8:24]))


# -- sequence numbers and sets ----------------------------------------------------------------


def pack_sn(sn: int) -> bytes:
    return struct.pack("<iI", sn >> 32, sn & 0xFFFFFFFF)


def unpack_sn(data: bytes, offset: int, little: bool) -> int:
    high, low = struct.unpack_from("<iI" if little else ">iI", data, offset)
    return int((high << 32) | low)


def pack_sn_set(base: int, members: list[int]) -> bytes:
    """A SequenceNumberSet: `base` and up to 256 members at or after it."""
    bits = 0 if not members else max(members) - base + 1
    words = [0] * ((bits + 31) // 32)
    for sn in members:
        d = sn - base
        words[d // 32] |= 1 << (31 - d % 32)
    return pack_sn(base) + struct.pack(f"<I{len(words)}I", bits, *words)


def unpack_sn_set(data: bytes, offset: int, little: bool) -> tuple[int, list[int], int]:
    """(base, members, offset after the set)."""
    base = unpack_sn(data, offset, little)
    (bits,) = struct.unpack_from("<I" if little else ">I", data, offset + 8)
    if bits > 256:
        raise WireError(f"a sequence number set of {bits} bits (at most 256)")
    nwords = (bits + 31) // 32
    words = struct.unpack_from(f"{'<' if little else '>'}{nwords}I", data, offset + 12)
    members = [base + i for i in range(bits) if words[i // 32] & (1 << (31 - i % 32))]
    return base, members, offset + 12 + 4 * nwords


# -- parameter lists --------------------------------------------------------------------------


def param(pid: int, value: bytes) -> bytes:
    padded = value + bytes(-len(value) % 4)
    return struct.pack("<HH", pid, len(padded)) + padded


def param_string(pid: int, text: str) -> bytes:
    raw = text.encode() + b"\x00"
    return param(pid, struct.pack("<I", len(raw)) + raw)


def param_octets(pid: int, data: bytes) -> bytes:
    return param(pid, struct.pack("<I", len(data)) + data)


def param_list(*params: bytes) -> bytes:
    return b"".join(params) + struct.pack("<HH", PID_SENTINEL, 0)


def parse_params(data: bytes, offset: int, little: bool) -> tuple[list[tuple[int, bytes]], int]:
    """(pid, value) pairs up to the sentinel, and the offset after it."""
    out: list[tuple[int, bytes]] = []
    fmt = "<HH" if little else ">HH"
    while True:
        if offset + 4 > len(data):
            raise WireError("a parameter list without its sentinel")
        pid, length = struct.unpack_from(fmt, data, offset)
        offset += 4
        if pid == PID_SENTINEL:
            return out, offset
        if offset + length > len(data):
            raise WireError(f"parameter 0x{pid:04x} runs past the end")
        out.append((pid & 0x3FFF if not pid & 0x8000 else pid, data[offset : offset + length]))
        offset += length


def read_string(value: bytes, little: bool = True) -> str:
    (n,) = struct.unpack_from("<I" if little else ">I", value)
    return value[4 : 4 + n].rstrip(b"\x00").decode("utf-8", "replace")


def read_octets(value: bytes, little: bool = True) -> bytes:
    (n,) = struct.unpack_from("<I" if little else ">I", value)
    return bytes(value[4 : 4 + n])


# -- writing messages -------------------------------------------------------------------------


def header(prefix: bytes) -> bytes:
    return PROTOCOL + bytes(VERSION) + bytes(VENDOR) + prefix


def submessage(kind: int, flags: int, body: bytes) -> bytes:
    return struct.pack("<BBH", kind, flags | FLAG_LE, len(body)) + body


def info_dst(prefix: bytes) -> bytes:
    return submessage(INFO_DST, 0, prefix)


def info_ts(seconds: float) -> bytes:
    whole = int(seconds)
    return submessage(INFO_TS, 0, struct.pack("<iI", whole, int((seconds - whole) * 2**32) & 0xFFFFFFFF))


def data(reader: bytes, writer: bytes, sn: int, payload: bytes | None, inline_qos: bytes = b"") -> bytes:
    flags = (0x02 if inline_qos else 0) | (0x04 if payload is not None else 0)
    pad = -len(payload or b"") % 4
    if payload is not None and pad and len(payload) >= 4:  # the encapsulation's options say how much padding
        payload = payload[:3] + bytes([payload[3] | pad]) + payload[4:] + bytes(pad)
    body = struct.pack("<HH", 0, 16) + reader + writer + pack_sn(sn) + inline_qos + (payload or b"")
    return submessage(DATA, flags, body + bytes(-len(body) % 4))


def heartbeat(reader: bytes, writer: bytes, first: int, last: int, count: int, final: bool = False) -> bytes:
    body = reader + writer + pack_sn(first) + pack_sn(last) + struct.pack("<i", count)
    return submessage(HEARTBEAT, 0x02 if final else 0, body)


def acknack(reader: bytes, writer: bytes, base: int, missing: list[int], count: int, final: bool = False) -> bytes:
    body = reader + writer + pack_sn_set(base, missing) + struct.pack("<i", count)
    return submessage(ACKNACK, 0x02 if final else 0, body)


def gap(reader: bytes, writer: bytes, start: int, end_exclusive: int) -> bytes:
    """Sequence numbers [start, end_exclusive) are not for this reader."""
    return submessage(GAP, 0, reader + writer + pack_sn(start) + pack_sn_set(end_exclusive, []))


# -- reading messages -------------------------------------------------------------------------


@dataclass
class Submessage:
    kind: int
    flags: int
    little: bool
    body: bytes
    source: bytes  # the sending participant's GUID prefix (INFO_SRC applied)
    destination: bytes  # INFO_DST's prefix, or 12 zero bytes (everyone)
    timestamp: float | None = None


@dataclass
class Data:
    reader: bytes
    writer: bytes
    sn: int
    inline_qos: list[tuple[int, bytes]] = field(default_factory=list)
    payload: bytes | None = None
    key_only: bool = False


def parse_message(datagram: bytes) -> tuple[tuple[int, int], bytes, list[Submessage]]:
    """(vendor id, source prefix, submessages) of one datagram."""
    if len(datagram) < 20 or datagram[:4] != PROTOCOL:
        raise WireError("not an RTPS message")
    vendor = (datagram[6], datagram[7])
    source = bytes(datagram[8:20])
    destination = bytes(12)
    timestamp: float | None = None
    out: list[Submessage] = []
    offset = 20
    while offset + 4 <= len(datagram):
        kind, flags = datagram[offset], datagram[offset + 1]
        little = bool(flags & FLAG_LE)
        (length,) = struct.unpack_from("<H" if little else ">H", datagram, offset + 2)
        offset += 4
        if length == 0 and kind not in (PAD, INFO_TS):
            length = len(datagram) - offset  # "to the end of the message"
        body = datagram[offset : offset + length]
        if len(body) < length:
            raise WireError("a submessage runs past the end of the datagram")
        offset += length
        if kind == INFO_DST:
            destination = bytes(body[:12])
        elif kind == INFO_SRC and len(body) >= 20:
            source = bytes(body[8:20])
        elif kind == INFO_TS:
            if flags & 0x02 or len(body) < 8:
                timestamp = None
            else:
                sec, frac = struct.unpack_from("<iI" if little else ">iI", body)
                timestamp = sec + frac / 2**32
        else:
            out.append(Submessage(kind, flags, little, bytes(body), source, destination, timestamp))
    return vendor, source, out


def parse_data(sub: Submessage) -> Data:
    body, little = sub.body, sub.little
    if len(body) < 20:
        raise WireError("a DATA submessage shorter than its header")
    (to_inline,) = struct.unpack_from("<H" if little else ">H", body, 2)
    reader, writer = body[4:8], body[8:12]
    sn = unpack_sn(body, 12, little)
    offset = 4 + to_inline
    inline: list[tuple[int, bytes]] = []
    if sub.flags & 0x02:
        inline, offset = parse_params(body, offset, little)
    payload = body[offset:] if sub.flags & 0x0C else None
    return Data(reader, writer, sn, inline, payload, bool(sub.flags & 0x08) and not sub.flags & 0x04)


def parse_heartbeat(sub: Submessage) -> tuple[bytes, bytes, int, int, int, bool]:
    """(reader, writer, first, last, count, final)."""
    b = sub.body
    if len(b) < 28:
        raise WireError("a HEARTBEAT shorter than 28 bytes")
    (count,) = struct.unpack_from("<i" if sub.little else ">i", b, 24)
    return b[0:4], b[4:8], unpack_sn(b, 8, sub.little), unpack_sn(b, 16, sub.little), count, bool(sub.flags & 0x02)


def parse_acknack(sub: Submessage) -> tuple[bytes, bytes, int, list[int]]:
    """(reader, writer, base, missing)."""
    b = sub.body
    base, missing, _ = unpack_sn_set(b, 8, sub.little)
    return b[0:4], b[4:8], base, missing


def parse_gap(sub: Submessage) -> tuple[bytes, bytes, list[int], int]:
    """(reader, writer, irrelevant sequence numbers below the list's base, the list's base)."""
    b = sub.body
    start = unpack_sn(b, 8, sub.little)
    base, members, _ = unpack_sn_set(b, 16, sub.little)
    return b[0:4], b[4:8], [*range(start, base), *members], base


def iter_locators(params: list[tuple[int, bytes]], pid: int) -> Iterator[Locator]:
    for p, value in params:
        if p == pid:
            locator = Locator.unpack(value)
            if locator.kind == LOCATOR_UDPV4:
                yield locator
