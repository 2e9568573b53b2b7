"""The CDR bytes we write are the bytes rosbags writes for the same ROS 2 message, and back."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.ros2 import msgs

from .rosbags_types import plain, to_rosbags, typestore

STORE = typestore()

text = st.text(max_size=12)
f64 = st.floats(allow_nan=False, width=64)
u32 = st.integers(0, 2**32 - 1)
times = st.builds(msgs.Time, sec=st.integers(-(2**31), 2**31 - 1), nanosec=st.integers(0, 999_999_999))
headers = st.builds(msgs.Header, stamp=times, frame_id=text)
dimensions = st.builds(msgs.MultiArrayDimension, label=text, size=u32, stride=u32)
layouts = st.builds(msgs.MultiArrayLayout, dim=st.lists(dimensions, max_size=3), data_offset=u32)
key_values = st.builds(msgs.KeyValue, key=text, value=text)
statuses = st.builds(
    msgs.DiagnosticStatus,
    level=st.integers(0, 3),
    name=text,
    message=text,
    hardware_id=text,
    values=st.lists(key_values, max_size=4),
)
STRATEGIES: dict[str, st.SearchStrategy[Any]] = {
    "builtin_interfaces/msg/Time": times,
    "std_msgs/msg/Header": headers,
    "std_msgs/msg/Bool": st.builds(msgs.Bool, data=st.booleans()),
    "std_msgs/msg/MultiArrayDimension": dimensions,
    "std_msgs/msg/MultiArrayLayout": layouts,
    "std_msgs/msg/Float64MultiArray": st.builds(msgs.Float64MultiArray, layout=layouts, data=st.lists(f64, max_size=9)),
    "sensor_msgs/msg/JointState": st.builds(
        msgs.JointState,
        header=headers,
        name=st.lists(text, max_size=4),
        position=st.lists(f64, max_size=4),
        velocity=st.lists(f64, max_size=4),
        effort=st.lists(f64, max_size=4),
    ),
    "diagnostic_msgs/msg/KeyValue": key_values,
    "diagnostic_msgs/msg/DiagnosticStatus": statuses,
    "diagnostic_msgs/msg/DiagnosticArray": st.builds(
        msgs.DiagnosticArray, header=headers, status=st.lists(statuses, max_size=3)
    ),
    "nurimc_msgs/msg/Frame": st.builds(
        msgs.Frame,
        stamp=times,
        direction=st.sampled_from(["tx", "rx"]),
        id=st.integers(0, 255),
        name=text,
        data=st.lists(st.integers(0, 255), max_size=14),
        dropped_before=u32,
    ),
}


def test_every_type_is_covered() -> None:
    assert set(STRATEGIES) == set(msgs.TYPES)


@pytest.mark.parametrize("ros_type", sorted(STRATEGIES))
@settings(max_examples=40, deadline=None)
@given(data=st.data())
def test_cdr_equals_rosbags_both_ways(ros_type: str, data: st.DataObject) -> None:
    ours = data.draw(STRATEGIES[ros_type])
    assert msgs.ros_type_of(ours) == ros_type
    theirs = to_rosbags(STORE, ours)
    their_bytes = bytes(STORE.serialize_cdr(theirs, ros_type))
    assert ours.serialize() == their_bytes  # what we write is what a ROS 2 node writes
    assert msgs.TYPES[ros_type].deserialize(their_bytes) == ours  # and what it writes decodes here
    assert plain(STORE.deserialize_cdr(ours.serialize(), ros_type)) == plain(theirs)


def test_a_joint_state_by_hand() -> None:
    """A fixed example, readable on its own: names, radians, the stamp."""
    ours = msgs.JointState(
        header=msgs.Header(stamp=msgs.Time(sec=12, nanosec=500), frame_id="base"),
        name=["motor_1", "motor_2"],
        position=[math.pi / 2, -1.0],
        velocity=[2.0, 0.0],
        effort=[0.3, 0.0],
    )
    decoded: Any = STORE.deserialize_cdr(ours.serialize(), "sensor_msgs/msg/JointState")
    assert decoded.name == ["motor_1", "motor_2"]
    assert decoded.position.tolist() == [math.pi / 2, -1.0]
    assert (decoded.header.stamp.sec, decoded.header.stamp.nanosec, decoded.header.frame_id) == (12, 500, "base")
    assert ours.serialize()[:4] == b"\x00\x01\x00\x00"  # CDR, little endian: what ROS 2 sends


def test_dds_type_names_follow_ros2() -> None:
    for ros_type, cls in msgs.TYPES.items():
        package, _, name = ros_type.split("/")
        assert cls.__idl_typename__ == f"{package}::msg::dds_::{name}_"


def test_schema_definitions_parse_in_rosbags() -> None:
    """Our ros2msg texts describe the same fields rosbags knows for the standard types."""
    from rosbags.typesys import get_types_from_msg

    for ros_type in msgs.TYPES:
        own = msgs.definition(ros_type).split("=" * 80)[0]
        parsed = get_types_from_msg(own, ros_type)[ros_type]
        assert [f[0] for f in parsed[1]] == [f[0] for f in STORE.fielddefs[ros_type][1]], ros_type
