"""ROS 2's type hash (RIHS01) of a message type, computed from our DDS type, for endpoint USER_DATA.

Since Iron every rmw puts `typehash=RIHS01_<sha256>;` in the USER_DATA of its readers and
writers; `ros2 topic info -v` and rclpy's TopicEndpointInfo show it (INVALID without it). The
hash (REP 2011) is the SHA-256 of a type description: the type's fields, each with a type id
(type_description_interfaces/msg/FieldType), array capacity, string bound and nested type name,
then the descriptions of every type it refers to, sorted by name; written as JSON with ", " and
": " separators, in that key order. We build the description from the Cyclone DDS dataclass, whose
fields are the message's in order (tests compare the results with the hashes ROS 2's wheels ship).
"""

from __future__ import annotations

import hashlib
import json
import typing
from functools import cache
from typing import Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, bounded_str, sequence

#: type_description_interfaces/msg/FieldType: the scalar ids; arrays add 48, bounded sequences 96,
#: unbounded sequences 144
NESTED, STRING, BOUNDED_STRING = 1, 17, 21
SCALARS = {
    "int8": 2,
    "uint8": 3,
    "int16": 4,
    "uint16": 5,
    "int32": 6,
    "uint32": 7,
    "int64": 8,
    "uint64": 9,
    "float32": 10,
    "float64": 11,
    "char": 13,
    "byte": 16,
}
ARRAY, BOUNDED_SEQUENCE, UNBOUNDED_SEQUENCE = 48, 96, 144


def ros_name(data_type: type[IdlStruct]) -> str:
    """ "sensor_msgs::msg::dds_::JointState_" -> "sensor_msgs/msg/JointState"."""
    package, kind, _, name = data_type.__idl_typename__.split("::")
    return f"{package}/{kind}/{name.removesuffix('_')}"


def _element(annotation: Any) -> tuple[int, int, str, type[IdlStruct] | None]:
    """(type id, string bound, nested type name, nested type) of a scalar, string or nested field."""
    if isinstance(annotation, type) and issubclass(annotation, IdlStruct):
        return NESTED, 0, ros_name(annotation), annotation
    if annotation is bool:
        return 15, 0, "", None
    if annotation is str:
        return STRING, 0, "", None
    if annotation is float:
        return SCALARS["float64"], 0, "", None
    metadata = getattr(annotation, "__metadata__", ())
    for marker in metadata:
        if isinstance(marker, str) and marker in SCALARS:
            return SCALARS[marker], 0, "", None
        if isinstance(marker, bounded_str):
            return BOUNDED_STRING, marker.max_length, "", None
    raise TypeError(f"no ROS 2 field type for {annotation!r}")


def _field(name: str, annotation: Any) -> tuple[dict[str, Any], type[IdlStruct] | None]:
    capacity, offset = 0, 0
    for marker in getattr(annotation, "__metadata__", ()):
        if isinstance(marker, array):
            capacity, offset, annotation = marker.length, ARRAY, marker.subtype
        elif isinstance(marker, sequence):
            bound = marker.max_length
            capacity, offset = (bound, BOUNDED_SEQUENCE) if bound else (0, UNBOUNDED_SEQUENCE)
            annotation = marker.subtype
    type_id, string_capacity, nested_name, nested = _element(annotation)
    field_type = {
        "type_id": type_id + offset,
        "capacity": capacity,
        "string_capacity": string_capacity,
        "nested_type_name": nested_name,
    }
    return {"name": name, "type": field_type}, nested


def _describe(data_type: type[IdlStruct], seen: dict[str, dict[str, Any]]) -> dict[str, Any]:
    fields = []
    for name, annotation in typing.get_type_hints(data_type, include_extras=True).items():
        field, nested = _field(name, annotation)
        fields.append(field)
        if nested is not None and ros_name(nested) not in seen:
            seen[ros_name(nested)] = {}  # placeholder against cycles
            seen[ros_name(nested)] = _describe(nested, seen)
    return {"type_name": ros_name(data_type), "fields": fields}


def type_description(data_type: type[IdlStruct]) -> dict[str, Any]:
    """The hashed form of type_description_interfaces/msg/TypeDescription (default values left out)."""
    referenced: dict[str, dict[str, Any]] = {}
    own = _describe(data_type, referenced)
    return {"type_description": own, "referenced_type_descriptions": [referenced[n] for n in sorted(referenced)]}


@cache
def type_hash(data_type: type[IdlStruct]) -> str:
    """RIHS01_<64 hex digits>."""
    text = json.dumps(type_description(data_type), separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def user_data(data_type: type[IdlStruct]) -> bytes:
    """An endpoint's USER_DATA as rmw writes it."""
    return f"typehash={type_hash(data_type)};".encode()
