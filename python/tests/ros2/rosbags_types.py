"""Our messages <-> rosbags' (an independent ROS 2 message implementation), field by field."""

from __future__ import annotations

from dataclasses import fields, is_dataclass
from typing import Any, cast

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from nurimc.ros2 import msgs

NAME, SEQUENCE = 2, 4  # rosbags' node types


def typestore() -> Typestore:
    """ROS 2 Humble's message types, plus ours registered from the schema text we write to MCAP."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(msgs.definition("nurimc_msgs/msg/Frame"), "nurimc_msgs/msg/Frame"))
    return store


def to_rosbags(store: Typestore, message: Any) -> Any:
    ros_type = msgs.ros_type_of(message)
    _, field_defs = store.fielddefs[ros_type]
    values: dict[str, Any] = {}
    for name, (node_type, detail) in field_defs:
        value = getattr(message, name)
        if node_type == NAME:
            value = to_rosbags(store, value)
        elif node_type == SEQUENCE:
            (inner_type, inner), _ = cast(Any, detail)
            if inner_type == NAME:
                value = [to_rosbags(store, v) for v in value]
            elif inner[0] == "string":
                value = list(value)
            else:
                value = np.array(value, dtype=inner[0])
        values[name] = value
    return store.types[ros_type](**values)


def plain(value: Any) -> Any:
    """Nested plain values of either side's message (dataclasses both), for comparing."""
    if is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in fields(value) if not f.name.startswith("__")}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
