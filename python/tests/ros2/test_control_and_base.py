"""ros2_control's JointState commands and the mobile base, without a bus or DDS: commands -> actions."""

from __future__ import annotations

import math

import pytest

from nurimc.ros2 import convert, msgs
from nurimc.ros2.bridge import Bridge, Hold, MoveTo, Refused, Run
from nurimc.ros2.control_topics import JointCommands
from nurimc.ros2.diffdrive import POSE_COVARIANCE, BaseConfig, DiffDrive
from nurimc.ros2.graph import Gid, NodeEntitiesInfo, ParticipantEntitiesInfo, node_name
from nurimc.ros2.names import NameError_
from nurimc.ros2.typehash import type_description, type_hash, user_data

from .test_bridge import state


def arm() -> Bridge:
    b = Bridge([1, 2], ["shoulder", "elbow"])
    b.readings({1: state(1, 0.0), 2: state(2, 0.0)})
    return b


# -- ros2_control's topic-based interface ---------------------------------------------------------


def test_positions_by_joint_name_in_any_order() -> None:
    logic = JointCommands(arm())
    actions = logic.command(["elbow", "shoulder"], [math.pi, math.pi / 2], [], [], now=0.0)
    assert actions == [MoveTo(2, 180.0, 60.0), MoveTo(1, 90.0, 60.0)]


def test_a_position_moves_at_the_velocity_that_comes_with_it() -> None:
    logic = JointCommands(arm())
    actions = logic.command(["shoulder", "elbow"], [1.0, 0.5], [2 * math.pi, 0.0], [], now=0.0)
    # 2π rad/s = 60 RPM; a zero velocity (a trajectory's end) moves at --move-velocity (60 RPM)
    assert actions == [
        MoveTo(1, round(convert.rad_to_deg(1.0), 2), 60.0),
        MoveTo(2, round(convert.rad_to_deg(0.5), 2), 60.0),
    ]
    # the same command again within 0.25 s is not re-sent; a new position is
    assert logic.command(["shoulder", "elbow"], [1.0, 0.5], [2 * math.pi, 0.0], [], now=0.1) == []
    assert logic.command(["shoulder", "elbow"], [1.1, 0.5], [2 * math.pi, 0.0], [], now=0.2) == [
        MoveTo(1, round(convert.rad_to_deg(1.1), 2), 60.0)
    ]


def test_velocity_alone_turns_and_zero_holds() -> None:
    b = arm()
    logic = JointCommands(b)
    assert logic.command(["elbow"], [], [2.0], [], now=0.0) == [Run(2, round(convert.rad_s_to_rpm(2.0), 1), 0.1)]
    assert b.joints[1].mode == "velocity" and b.joints[0].mode == "idle"  # the shoulder was not commanded
    assert logic.command(["elbow"], [], [0.0], [], now=0.1) == [Hold(2)]
    assert b.expire(10.0) == []  # held: nothing left to time out


def test_names_of_another_bridge_are_skipped() -> None:
    logic = JointCommands(arm())
    assert logic.command(["wheel"], [1.0], [], [], now=0.0) == []
    assert logic.command(["wheel", "shoulder"], [1.0, 0.5], [], [], now=0.0) == [
        MoveTo(1, round(convert.rad_to_deg(0.5), 2), 60.0)
    ]
    assert logic.bridge.counters.refused == 0


@pytest.mark.parametrize(
    ("position", "velocity", "effort", "why"),
    [
        ([1.0], [], [], "1 position values for 2 joint names"),
        ([], [1.0, 2.0, 3.0], [], "3 velocity values for 2 joint names"),
        ([1.0, math.nan], [], [], "position nan is not a number"),
        ([], [], [1.0, 0.0], "effort commands are not supported"),
        ([0.0, convert.deg_to_rad(700)], [], [], "out of the controller's reach"),
    ],
)
def test_a_wrong_joint_command_is_refused_whole(
    position: list[float], velocity: list[float], effort: list[float], why: str
) -> None:
    b = arm()
    with pytest.raises(Refused, match=why):
        JointCommands(b).command(["shoulder", "elbow"], position, velocity, effort, now=0.0)
    assert b.counters.refused == 1 and [j.mode for j in b.joints] == ["idle", "idle"]


def test_joint_commands_are_refused_while_the_estop_is_latched() -> None:
    b = arm()
    b.estop(True, now=0.0)
    with pytest.raises(Refused, match="estop is latched"):
        JointCommands(b).command(["shoulder"], [1.0], [], [], now=0.1)


# -- the mobile base ------------------------------------------------------------------------------


def base(**options: float | bool) -> tuple[Bridge, DiffDrive]:
    b = Bridge([1, 2], ["left", "right"])
    b.readings({1: state(1, 0.0), 2: state(2, 0.0)})
    config = BaseConfig(1, 2, wheel_radius=0.1, wheel_separation=0.4, left_inverted=True, **options)  # type: ignore[arg-type]
    return b, DiffDrive(b, config)


def test_wheel_speeds_and_signs() -> None:
    _, drive = base()
    # 0.5 m/s straight: 5 rad/s per wheel = 47.7 RPM; the left motor is inverted
    assert drive.wheel_rpms(0.5, 0.0) == (-47.7, 47.7)
    # turning on the spot at 1 rad/s: each wheel 0.2 m/s = 2 rad/s, both motors the same way
    assert drive.wheel_rpms(0.0, 1.0) == (19.1, 19.1)


def test_the_base_accelerates_within_its_limit_and_clamps_its_speed() -> None:
    _, drive = base(max_linear=0.5, max_linear_accel=1.0)
    drive.command(2.0, 0.0, now=0.0)  # beyond --max-linear: clamped to 0.5 m/s
    assert drive.target == (0.5, 0.0)
    drive.tick(0.0)
    speeds = []
    for k in range(1, 40):
        drive.tick(k * 0.02)
        speeds.append(drive.current[0])
    assert speeds[0] == pytest.approx(0.02) and speeds[9] == pytest.approx(0.2)  # 1 m/s²
    assert max(speeds) == pytest.approx(0.5)


def test_the_command_timeout_decelerates_then_holds_never_releases() -> None:
    b, drive = base(timeout=0.5, max_linear_accel=1.0)
    drive.command(0.5, 0.0, now=0.0)
    actions = []
    for k in range(0, 100):  # 2 s at 50 Hz; the last command at t = 0
        actions += drive.tick(k * 0.02)
    speeds = [a.rpm for a in actions if isinstance(a, Run) and a.id == 2]
    assert max(speeds) == 47.7  # reached 0.5 m/s
    falling = speeds[speeds.index(47.7) :]
    assert len([s for s in falling if 0 < s < 47.7]) > 10  # down through intermediate speeds
    assert actions[-2:] == [Hold(1), Hold(2)]  # then hold: control stays on
    assert drive.timeouts == 1 and [j.mode for j in b.joints] == ["held", "held"]


def test_the_base_stops_on_estop_and_refuses_commands_while_latched() -> None:
    b, drive = base()
    drive.command(0.5, 0.0, now=0.0)
    drive.tick(0.0)
    drive.tick(0.1)
    b.estop(True, now=0.1)
    assert drive.tick(0.12) == [] and drive.current == (0.0, 0.0)
    with pytest.raises(Refused, match="estop is latched"):
        drive.command(0.5, 0.0, now=0.2)
    b.estop(False, now=0.3)  # unlatched: the wheels stay released until the next command, then start from 0
    assert drive.tick(0.32) == []
    drive.command(0.5, 0.0, now=0.34)
    assert drive.tick(0.36) == [Run(1, -3.8, 0.1), Run(2, 3.8, 0.1)]  # 0.04 m/s after 40 ms at 1 m/s²


def test_odometry_integrates_the_wheels() -> None:
    b, drive = base()
    drive.update_odometry()
    # both wheels one turn forward (the left motor turns backwards for that): 2π·0.1 m straight ahead
    b.readings({1: state(1, -360.0, speed=60.0), 2: state(2, 360.0, speed=60.0)})
    b.joints[0].sign, b.joints[1].sign = -1.0, 1.0
    assert drive.update_odometry()
    assert [drive.x, drive.y, drive.yaw] == pytest.approx([2 * math.pi * 0.1, 0.0, 0.0])
    assert drive.linear == pytest.approx(2 * math.pi * 0.1)  # 60 RPM of a 0.1 m wheel
    # the right wheel a quarter turn more: turned left by (π/2·0.1)/0.4 rad
    b.readings({1: state(1, -360.0), 2: state(2, 450.0)})
    drive.update_odometry()
    assert drive.yaw == pytest.approx(math.pi / 2 * 0.1 / 0.4)
    odom, tf = drive.odometry(1_700_000_000_000_000_000)
    assert odom.header.frame_id == "odom" and odom.child_frame_id == "base_link"
    assert odom.pose.pose.orientation.z == pytest.approx(math.sin(drive.yaw / 2))
    assert [odom.pose.covariance[i * 7] for i in range(6)] == list(POSE_COVARIANCE)
    assert tf.transforms[0].transform.translation.x == odom.pose.pose.position.x


def test_a_wheel_that_did_not_answer_skips_the_odometry() -> None:
    b, drive = base()
    drive.update_odometry()
    b.readings({1: state(1, 10.0), 2: RuntimeError("no answer")})
    assert not drive.update_odometry()


@pytest.mark.parametrize(
    ("options", "why"),
    [
        ({"left_id": 2}, "two different IDs"),
        ({"right_id": 9}, "ID 9 is not among the bridge's motors"),
        ({"wheel_radius": 0.0}, "--wheel-radius 0.0: give a number > 0"),
        ({"max_linear": 700.0}, "the wheels would need more than"),
        ({"odom_frame": "/odom"}, "without a leading '/'"),
    ],
)
def test_a_wrong_base_set_up_is_refused(options: dict[str, object], why: str) -> None:
    b = Bridge([1, 2], ["l", "r"])
    settings: dict[str, object] = {"left_id": 1, "right_id": 2, "wheel_radius": 0.1, "wheel_separation": 0.4}
    with pytest.raises(ValueError, match=why):
        DiffDrive(b, BaseConfig(**{**settings, **options}))  # type: ignore[arg-type]


# -- the node graph -------------------------------------------------------------------------------


def test_node_names_follow_ros2_rules() -> None:
    assert node_name("nurimc_2") == "nurimc_2"
    for bad in ("", "2arm", "a-b", "a/b", "x" * 256):
        with pytest.raises(NameError_):
            node_name(bad)


def test_the_graph_message_is_rmw_dds_common_on_the_wire() -> None:
    """Bytes as rmw writes ParticipantEntitiesInfo: the gid's 16 bytes, then the node's strings and gid lists."""
    gid = list(range(16))
    message = ParticipantEntitiesInfo(Gid(gid), [NodeEntitiesInfo("/arm", "nurimc", [], [Gid(gid)])])
    data = message.serialize()
    body = data[4:]
    assert body[:16] == bytes(gid)
    assert body[16:20] == (1).to_bytes(4, "little")  # one node
    assert body[20:24] == (5).to_bytes(4, "little") and body[24:29] == b"/arm\0"
    assert body[29:32] == b"\0\0\0" and body[32:36] == (7).to_bytes(4, "little") and body[36:43] == b"nurimc\0"
    assert body[44:48] == (0).to_bytes(4, "little") and body[48:52] == (1).to_bytes(4, "little")  # no readers, 1 writer
    assert body[52:68] == bytes(gid) and len(body) == 68
    assert ParticipantEntitiesInfo.deserialize(data).serialize() == data


def test_endpoints_carry_ros2_type_hashes() -> None:
    """RIHS01 as ROS 2 Jazzy and Kilted ship them (sensor_msgs 5.x, std_msgs): USER_DATA `typehash=...;`."""
    assert type_hash(msgs.JointState) == "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
    assert type_hash(msgs.Header) == "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
    assert user_data(msgs.Time) == b"typehash=RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197;"
    description = type_description(msgs.JointState)
    assert [t["type_name"] for t in description["referenced_type_descriptions"]] == [
        "builtin_interfaces/msg/Time",
        "std_msgs/msg/Header",
    ]


def test_the_base_reports_itself_in_diagnostics() -> None:
    b, drive = base()
    drive.command(0.5, 0.0, now=0.0)
    drive.tick(0.0)
    drive.tick(0.1)
    status = drive.status("nurimc/base")
    values = {kv.key: kv.value for kv in status.values}
    assert status.name == "nurimc/base: base" and status.message == "moving"
    assert values["target_linear_m_s"] == "0.5000" and values["commanded_linear_m_s"] == "0.1000"
    b.estop(True, now=0.2)
    assert drive.status("p").message == "released by estop (latched)"
