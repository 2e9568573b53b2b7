"""Run in a ROS 2 venv (build/ros-<release>/venv): the CDR bytes rclpy's serialize_message gives.

stdin: a JSON list of {"type": "pkg/msg/Name" | "pkg/srv/Name_Request" | "pkg/srv/Name_Response",
"value": {field: value, ...}} (nested messages as objects, byte fields as integers).
stdout: a JSON list with the hex of each, or null for a type this venv does not have.
"""

# mypy: ignore-errors
# (rclpy and rosidl_parser exist only in the ROS 2 venvs, not in the one mypy runs in)

from __future__ import annotations

import importlib
import json
import sys
from typing import Any

from rclpy.serialization import serialize_message
from rosidl_parser.definition import AbstractNestedType, BasicType, NamespacedType


def resolve(type_name: str) -> Any:
    package, kind, name = type_name.split("/")
    module = importlib.import_module(f"{package}.{kind}")
    for part in ("_Request", "_Response"):
        if name.endswith(part):
            return getattr(getattr(module, name.removesuffix(part)), part[1:])
    return getattr(module, name)


def convert(slot: Any, value: Any) -> Any:
    if isinstance(slot, NamespacedType):
        return build(resolve("/".join([*slot.namespaces, slot.name])), value)
    if isinstance(slot, AbstractNestedType):
        return [convert(slot.value_type, v) for v in value]
    if isinstance(slot, BasicType) and slot.typename == "octet":
        return bytes([value])
    return value


def build(cls: Any, data: dict[str, Any]) -> Any:
    message = cls()
    for name, slot in zip(cls.get_fields_and_field_types(), cls.SLOT_TYPES, strict=True):
        if name in data:
            setattr(message, name, convert(slot, data[name]))
    return message


def main() -> None:
    out: list[str | None] = []
    for item in json.load(sys.stdin):
        try:
            cls = resolve(item["type"])
        except (ImportError, AttributeError):
            out.append(None)
            continue
        out.append(serialize_message(build(cls, item["value"])).hex())
    print(json.dumps(out))


if __name__ == "__main__":
    main()
