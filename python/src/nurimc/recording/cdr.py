"""A pure-Python CDR writer for the ROS 2 messages nurimc records, so writing an MCAP file needs
only the `mcap` package (no DDS stack: `pip install 'nurimc[record]'`).

The layout of each type is read from its `ros2msg` definition (ros2/msgs.py `definition`), the
same text written into the file as its schema, so the schema and the bytes cannot disagree.
The encoding is what ROS 2 (rmw_cyclonedds, rmw_fastrtps) and rosbag2 write: XCDR1 plain data,
little-endian (header 00 01 00 00), each value aligned to its size (8 for float64) from the start
of the data after the header; a string is its uint32 length counting the NUL, the UTF-8 bytes,
the NUL; a sequence is its uint32 count then its items; a fixed array is its items only; no
padding after the last value. Tests compare the bytes with Cyclone DDS's for the same messages.

`IdlStruct` and the scalar names here stand in for Cyclone DDS's when it is not installed: the
message classes of ros2/msgs.py are then plain dataclasses whose `serialize()` is this writer.
"""

from __future__ import annotations

import struct
from functools import cache
from typing import Any

#: scalar ros2msg type -> (struct format, size)
PRIMITIVES: dict[str, tuple[str, int]] = {
    "bool": ("?", 1),
    "byte": ("B", 1),
    "char": ("B", 1),
    "int8": ("b", 1),
    "uint8": ("B", 1),
    "int16": ("h", 2),
    "uint16": ("H", 2),
    "int32": ("i", 4),
    "uint32": ("I", 4),
    "int64": ("q", 8),
    "uint64": ("Q", 8),
    "float32": ("f", 4),
    "float64": ("d", 8),
}
ENCAPSULATION = b"\x00\x01\x00\x00"  # CDR_LE, no options

#: ROS 2's RIHS01 type hash of each message type nurimc writes, as ros2/typehash.py computes it
#: from the Cyclone DDS type (a test checks each against it): the channels' `topic_type_hash`
#: without a DDS stack
TYPE_HASHES: dict[str, str] = {
    "builtin_interfaces/msg/Time": "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
    "std_msgs/msg/Header": "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
    "std_msgs/msg/Bool": "RIHS01_feb91e995ff9ebd09c0cb3d2aed18b11077585839fb5db80193b62d74528f6c9",
    "std_msgs/msg/MultiArrayDimension": "RIHS01_5e773a60a4c7fc8a54985f307c7837aa2994252a126c301957a24e31282c9cbe",
    "std_msgs/msg/MultiArrayLayout": "RIHS01_4c66e6f78e740ac103a94cf63259f968e48c617e7699e829b63c21a5cb50dac6",
    "std_msgs/msg/Float64MultiArray": "RIHS01_1025ddc6b9552d191f89ef1a8d2f60f3d373e28b283d8891ddcc974e8c55397f",
    "sensor_msgs/msg/JointState": "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e",
    "diagnostic_msgs/msg/KeyValue": "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42",
    "diagnostic_msgs/msg/DiagnosticStatus": "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4",
    "diagnostic_msgs/msg/DiagnosticArray": "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e",
    "nurimc_msgs/msg/Frame": "RIHS01_97a033ed94e89fb71a123bbd4ec92b7776d1de727e454c4e7697efde5e486470",
    "geometry_msgs/msg/Vector3": "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d",
    "geometry_msgs/msg/Point": "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881",
    "geometry_msgs/msg/Quaternion": "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684",
    "geometry_msgs/msg/Twist": "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
    "geometry_msgs/msg/TwistStamped": "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
    "geometry_msgs/msg/Pose": "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa",
    "geometry_msgs/msg/PoseWithCovariance": "RIHS01_9a7c0fd234b7f45c6098745ecccd773ca1085670e64107135397aee31c02e1bb",
    "geometry_msgs/msg/TwistWithCovariance": "RIHS01_49f574f033f095d8b6cd1beaca5ca7925e296e84af1716d16c89d38b059c8c18",
    "nav_msgs/msg/Odometry": "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
    "geometry_msgs/msg/Transform": "RIHS01_beb83fbe698636351461f6f35d1abb20010c43d55374d81bd041f1ba2581fddc",
    "geometry_msgs/msg/TransformStamped": "RIHS01_0a241f87d04668d94099cbb5ba11691d5ad32c2f29682e4eb5653424bd275206",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
}


class CdrError(ValueError):
    """A message that cannot be written as its type says (a wrong value, an unknown type)."""


# -- the layout of a type, from its ros2msg definition ------------------------------------------


class Field:
    """One field: `kind` is a primitive, "string" or a nested "pkg/msg/Type"; `count` is None for a
    single value, -1 for a sequence (bounded or not), N for a fixed array of N."""

    __slots__ = ("count", "kind", "name")

    def __init__(self, name: str, kind: str, count: int | None) -> None:
        self.name, self.kind, self.count = name, kind, count


def _sections(ros_type: str) -> dict[str, str]:
    """The definition of `ros_type` split into the text of each type it names (itself first)."""
    from ..ros2.definitions import definition  # the ros2msg texts; no DDS needed to read them

    texts: dict[str, str] = {}
    current = ros_type
    lines: list[str] = []
    for line in definition(ros_type).splitlines():
        if line.startswith("=" * 10):
            continue
        if line.startswith("MSG: "):
            texts[current] = "\n".join(lines)
            package, name = line[5:].strip().split("/")
            current, lines = f"{package}/msg/{name}", []
            continue
        lines.append(line)
    texts[current] = "\n".join(lines)
    return texts


def _resolve(kind: str, package: str) -> str:
    if kind in PRIMITIVES or kind in ("string", "wstring"):
        return kind
    if kind == "Header":  # ros2msg's shorthand
        return "std_msgs/msg/Header"
    if "/" not in kind:  # a type of the same package
        return f"{package}/msg/{kind}"
    parts = kind.split("/")
    return kind if len(parts) == 3 else f"{parts[0]}/msg/{parts[1]}"


def _parse(ros_type: str, text: str) -> list[Field]:
    package = ros_type.split("/")[0]
    fields: list[Field] = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        words = line.split()
        if len(words) < 2 or "=" in words[1] or (len(words) > 2 and words[2].startswith("=")):
            continue  # a constant (byte OK=0): not in the data
        kind, name = words[0], words[1]
        count: int | None = None
        if kind.endswith("]"):
            kind, _, size = kind[:-1].partition("[")
            count = -1 if size == "" or size.startswith("<=") else int(size)
        if kind.startswith("string<=") or kind.startswith("wstring<="):
            kind = kind.split("<=")[0]
        if kind == "wstring":
            raise CdrError(f"{ros_type}.{name}: wstring fields are not supported")
        fields.append(Field(name, _resolve(kind, package), count))
    return fields


@cache
def layout(ros_type: str) -> dict[str, list[Field]]:
    """Fields of `ros_type` and of every type it contains, by type name."""
    try:
        texts = _sections(ros_type)
    except KeyError:
        raise CdrError(f"no ros2msg definition of {ros_type}") from None
    return {name: _parse(name, text) for name, text in texts.items()}


# -- the writer ---------------------------------------------------------------------------------


class _Writer:
    def __init__(self, types: dict[str, list[Field]]) -> None:
        self.types = types
        self.out = bytearray()

    def _align(self, size: int) -> None:
        self.out += b"\0" * (-len(self.out) % size)

    def primitive(self, kind: str, value: Any) -> None:
        fmt, size = PRIMITIVES[kind]
        self._align(size)
        self.out += struct.pack("<" + fmt, value)

    def string(self, value: str) -> None:
        data = value.encode("utf-8")  # a NUL inside is written as it is (as Cyclone DDS does)
        self.primitive("uint32", len(data) + 1)
        self.out += data + b"\0"

    def value(self, kind: str, value: Any) -> None:
        if kind in PRIMITIVES:
            self.primitive(kind, value)
        elif kind == "string":
            self.string(value)
        else:
            self.struct(kind, value)

    def struct(self, ros_type: str, message: Any) -> None:
        try:
            fields = self.types[ros_type]
        except KeyError:
            raise CdrError(f"no layout for {ros_type}") from None
        for f in fields:
            value = getattr(message, f.name)
            if f.count is None:
                self.value(f.kind, value)
                continue
            items = list(value)
            if f.count == -1:
                self.primitive("uint32", len(items))
            elif len(items) != f.count:
                raise CdrError(f"{ros_type}.{f.name}: {len(items)} values, the type has {f.count}")
            if f.kind in PRIMITIVES and items:  # a run of scalars: aligned once, packed at once
                fmt, size = PRIMITIVES[f.kind]
                self._align(size)
                self.out += struct.pack(f"<{len(items)}{fmt}", *items)
            else:
                for item in items:
                    self.value(f.kind, item)


def serialize(ros_type: str, message: Any) -> bytes:
    """The CDR bytes (with the encapsulation header) of `message`, an object whose attributes are
    the fields of `ros_type` ("sensor_msgs/msg/JointState"): a nurimc.ros2.msgs instance, with or
    without Cyclone DDS installed."""
    writer = _Writer(layout(ros_type))
    try:
        writer.struct(ros_type, message)
    except struct.error as error:
        raise CdrError(f"{ros_type}: a value does not fit its field ({error})") from None
    return ENCAPSULATION + bytes(writer.out)


# -- stand-ins for Cyclone DDS's names when it is not installed ---------------------------------


def _ros_name(typename: str) -> str:
    """ "sensor_msgs::msg::dds_::JointState_" -> "sensor_msgs/msg/JointState"."""
    package, kind, _, name = typename.split("::")
    return f"{package}/{kind}/{name.removesuffix('_')}"


class IdlStruct:
    """The base of the message classes when Cyclone DDS is absent: the DDS type name as Cyclone
    keeps it (`__idl_typename__`), and `serialize()` by this module's writer."""

    __idl_typename__: str = ""

    def __init_subclass__(cls, typename: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.__idl_typename__ = typename or cls.__name__

    def serialize(self) -> bytes:
        return serialize(_ros_name(type(self).__idl_typename__), self)


# plain Python types for the field annotations (dataclasses only need a name for each)
byte = uint8 = uint32 = int32 = int
float64 = float
sequence = list
