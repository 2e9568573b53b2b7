"""--diff-drive with --mcap, --no-odom-tf and --frame-prefix: what is published and what is recorded.

The MCAP file holds odom, /tf and /diagnostics besides joint_states, each channel with the QoS
profile and RIHS01 type hash rosbag2 (Jazzy) writes, and schemas an independent reader (rosbags)
decodes the recorded bytes with.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from cyclonedds.idl import IdlStruct
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from nurimc.recording.mcap_file import OFFERED_QOS
from nurimc.ros2 import base_msgs, msgs
from nurimc.ros2.typehash import type_hash

from .peer import DiagnosticArray, JointState, Peer
from .test_end_to_end import BridgeProcess, peer, unique

__all__ = ["peer"]

BASE = ["--diff-drive", "1,2", "--wheel-radius", "0.1", "--wheel-separation", "0.4"]


def record(peer: Peer, tmp_path: Path, *options: str) -> tuple[str, dict[str, tuple[str, dict[str, str], list[bytes]]]]:
    """Run a base bridge until its /diagnostics came twice; the recording's channels by topic."""
    ns = unique("rec")
    diagnostics = peer.subscribe("/diagnostics", DiagnosticArray)
    states = peer.subscribe(f"{ns}/joint_states", JointState)
    path = tmp_path / "base.mcap"
    bridge = BridgeProcess(ns, "1,2", *BASE, "--mcap", str(path), *options)
    try:
        states.wait_for(lambda s: True, 10, "joint_states")
        mine = lambda d: any(s.name.startswith(f"nurimc{ns}: ") for s in d.status)  # noqa: E731
        diagnostics.wait_for(mine, 5, "our diagnostics")
        diagnostics.wait_for(mine, 5, "our diagnostics again")
    finally:
        assert bridge.stop() == 0, "".join(bridge.stderr)
    channels: dict[str, tuple[str, dict[str, str], list[bytes]]] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema is not None
            entry = channels.setdefault(channel.topic, (schema.data.decode(), dict(channel.metadata), []))
            entry[2].append(message.data)
    return ns, channels


def test_odom_tf_and_diagnostics_are_recorded_with_qos_and_type_hash(peer: Peer, tmp_path: Path) -> None:
    ns, channels = record(peer, tmp_path, "--frame-prefix", "r1/")
    assert {f"{ns}/joint_states", f"{ns}/odom", "/tf", "/diagnostics", "/nurimc/frames"} <= set(channels)
    types: dict[str, type[IdlStruct]] = {
        f"{ns}/joint_states": msgs.JointState,
        f"{ns}/odom": base_msgs.Odometry,
        "/tf": base_msgs.TFMessage,
        "/diagnostics": msgs.DiagnosticArray,
        "/nurimc/frames": msgs.Frame,
    }
    store = get_typestore(Stores.ROS2_JAZZY)
    for topic, data_type in types.items():
        schema, metadata, payloads = channels[topic]
        assert metadata["offered_qos_profiles"] == OFFERED_QOS, topic
        assert metadata["topic_type_hash"] == type_hash(data_type), topic
        if not topic.startswith("/nurimc"):  # rosbags decodes the bytes as the ROS 2 type
            name = msgs.ros_type_of(data_type.deserialize(payloads[0]))
            store.deserialize_cdr(payloads[-1], name)
            assert schema == msgs.definition(name)
    odom = base_msgs.Odometry.deserialize(channels[f"{ns}/odom"][2][-1])
    assert (odom.header.frame_id, odom.child_frame_id) == ("r1/odom", "r1/base_link")
    tf = base_msgs.TFMessage.deserialize(channels["/tf"][2][-1])
    assert tf.transforms[0].header.frame_id == "r1/odom"
    state = msgs.JointState.deserialize(channels[f"{ns}/joint_states"][2][-1])
    assert state.header.frame_id == "r1/base_link" and state.name == ["motor_1", "motor_2"]
    statuses = [msgs.DiagnosticArray.deserialize(p) for p in channels["/diagnostics"][2]]
    names = {s.name for a in statuses for s in a.status}
    assert {f"nurimc{ns}: base", f"nurimc{ns}: bus", f"nurimc{ns}: motor_1"} <= names


@pytest.mark.parametrize("release_store", [Stores.ROS2_JAZZY])
def test_the_schemas_are_ros2msg_that_rosbags_reads(release_store: Stores) -> None:
    """Each recorded type's schema text, read by rosbags, gives the fields our type has."""
    from rosbags.typesys import get_types_from_msg

    for name in ("nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage", "geometry_msgs/msg/TwistStamped"):
        text = msgs.definition(name)
        own, *sections = text.split("=" * 80 + "\n")
        found = get_types_from_msg(own, name)
        for section in sections:
            header, body = section.split("\n", 1)
            package, type_name = header.removeprefix("MSG: ").split("/")
            found |= get_types_from_msg(body, f"{package}/msg/{type_name}")
        reference = get_typestore(release_store).fielddefs[name]
        assert [f[0] for f in found[name][1]] == [f[0] for f in reference[1]], name


def test_no_odom_tf_publishes_odom_without_the_transform(peer: Peer, tmp_path: Path) -> None:
    ns, channels = record(peer, tmp_path, "--no-odom-tf")
    assert f"{ns}/odom" in channels and "/tf" not in channels
    odom = base_msgs.Odometry.deserialize(channels[f"{ns}/odom"][2][-1])
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_link")
