"""The bridge's rules, without a bus or DDS: commands -> actions, readings -> messages."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, cast

import pytest

from nurimc.errors import NoAnswer
from nurimc.procedures.motor import MotorState
from nurimc.ros2 import convert, msgs
from nurimc.ros2.bridge import MAX_RPM, Bridge, Hold, MoveTo, Refused, ReleaseAll, Run
from nurimc.ros2.dds import domain_id
from nurimc.ros2.names import NameError_, dds_topic, joint_names, namespace, topic

# pytest.approx compares equal to a float; typed as one so it can stand in a MoveTo
approx = cast(Callable[[float], float], pytest.approx)


def state(
    device_id: int, position: float, device: float | None = None, speed: float = 0.0, signed: bool = False
) -> MotorState:
    """A reading; by default one whose speed the library could not sign yet (position feedback's
    magnitude, no trend): the bridge signs it by the direction between its readings."""
    device = position if device is None else device
    return MotorState(device_id, position, device, speed, 0.4, "cw" if device < 0 else "ccw", speed_signed=signed)


def bridge(**options: Any) -> Bridge:
    b = Bridge([1, 2], ["a", "b"], **options)
    b.readings({1: state(1, 0.0), 2: state(2, 0.0)})
    return b


def test_position_commands_are_radians_in_the_published_frame() -> None:
    b = Bridge([1, 2], ["a", "b"])
    # motor 2 has made two whole turns of the device's 655.36 degree counter: continuous 1320.72, device 10
    b.readings({1: state(1, 0.0), 2: state(2, 1320.72, 10.0)})
    actions = b.position_command([math.pi / 2, convert.deg_to_rad(1330.72)], now=0.0)
    assert actions == [MoveTo(1, 90.0, approx(60.0)), MoveTo(2, 20.0, approx(60.0))]
    assert [j.mode for j in b.joints] == ["position", "position"]


@pytest.mark.parametrize(
    ("data", "why"),
    [
        ([1.0], "1 values for 2 joints"),
        ([1.0, 2.0, 3.0], "3 values for 2 joints"),
        ([1.0, math.nan], "b = nan is not a number"),
        ([math.inf, 0.0], "a = inf is not a number"),
        ([0.0, convert.deg_to_rad(700)], "out of the controller's reach"),
    ],
)
def test_a_wrong_position_command_is_refused_whole(data: list[float], why: str) -> None:
    b = bridge()
    with pytest.raises(Refused, match=why):
        b.position_command(data, now=0.0)
    assert b.counters.refused == 1 and why in b.counters.last_refusal
    assert [j.mode for j in b.joints] == ["idle", "idle"]


def test_no_position_command_before_a_reading() -> None:
    b = Bridge([1], ["a"])
    with pytest.raises(Refused, match="no reading of a yet"):
        b.position_command([0.5], now=0.0)


def test_velocity_commands_are_rad_per_s_and_zero_holds() -> None:
    b = bridge()
    assert b.velocity_command([2.0, -1.0], now=0.0) == [Run(1, 19.1, 0.1), Run(2, -9.5, 0.1)]
    assert b.velocity_command([0.0, -1.0], now=0.1) == [Hold(1)]  # unchanged speeds are not resent at once
    assert b.velocity_command([0.0, -1.0], now=0.4) == [Run(2, -9.5, 0.1)]  # ...but refreshed every 0.25 s
    with pytest.raises(Refused, match="beyond"):
        b.velocity_command([0.0, convert.rpm_to_rad_s(MAX_RPM + 1)], now=0.5)


def test_command_timeout_holds_a_turning_motor() -> None:
    b = bridge()
    b.velocity_command([2.0, 0.0], now=10.0)
    assert b.next_expiry() == pytest.approx(10.5)
    assert b.expire(10.4) == []
    assert b.expire(10.6) == [Hold(1)]
    assert b.joints[0].mode == "held" and b.counters.timeouts == 1
    assert b.expire(20.0) == [] and b.next_expiry() is None


def test_command_timeout_off() -> None:
    b = bridge(command_timeout=0)
    b.velocity_command([2.0, 1.0], now=0.0)
    assert b.expire(1e6) == [] and b.next_expiry() is None


def test_estop_releases_everything_and_latches() -> None:
    b = bridge()
    b.velocity_command([2.0, 2.0], now=0.0)
    assert b.estop(True, now=0.1) == [ReleaseAll((1, 2))]
    for command in (b.velocity_command, b.position_command):
        with pytest.raises(Refused, match="estop is latched"):
            command([0.0, 0.0], 0.2)
    assert b.expire(100.0) == []  # released joints are not "turning": nothing to time out
    assert b.estop(False, now=0.3) == []
    assert b.velocity_command([1.0, 0.0], now=0.4) == [Run(1, 9.5, 0.1)]  # released joint 2 stays released


def test_shutdown_holds_turning_joints() -> None:
    b = bridge()
    b.velocity_command([2.0, 0.0], now=0.0)
    assert b.shutdown() == [Hold(1)]


def test_joint_state_has_every_joint_in_order_with_a_stale_marker_and_ros_units() -> None:
    b = Bridge([1, 2], ["a", "b"], frame_id="robot1/base_link")
    b.readings({1: state(1, 90.0, speed=60.0), 2: NoAnswer("request_position", 2, 9600, 3)})
    message = b.joint_state(1_500_000_000_123)
    assert message is not None
    assert message.name == ["a", "b"]  # b never answered: there all the same, every value NaN
    assert message.position[0] == pytest.approx(math.pi / 2) and math.isnan(message.position[1])
    assert message.velocity[0] == pytest.approx(2 * math.pi)  # 60 RPM
    assert math.isnan(message.velocity[1]) and math.isnan(message.effort[1])
    assert message.effort[0] == 0.4  # amperes
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1500, 123)
    assert message.header.frame_id == "robot1/base_link"
    b.readings({1: state(1, 80.0, speed=60.0), 2: state(2, 45.0)})  # moving backwards: velocity is negative
    message = b.joint_state(0)
    assert message is not None and message.name == ["a", "b"]
    assert message.velocity[0] == pytest.approx(-2 * math.pi)
    assert message.position[1] == pytest.approx(math.pi / 4) and message.velocity[1] == 0.0
    # b stops answering: its last good position stays, velocity and effort turn NaN (the marker)
    b.readings({1: state(1, 80.0), 2: NoAnswer("request_position", 2, 9600, 3)})
    message = b.joint_state(0)
    assert message is not None and message.name == ["a", "b"]
    assert message.position[1] == pytest.approx(math.pi / 4)
    assert math.isnan(message.velocity[1]) and math.isnan(message.effort[1])
    assert not math.isnan(message.velocity[0])
    b.readings({1: state(1, 80.0), 2: state(2, 0.0)})  # back: fresh values again
    message = b.joint_state(0)
    assert message is not None and message.position[1] == 0.0 and message.effort[1] == 0.4


def test_effort_in_newton_metres_with_a_torque_constant() -> None:
    b = Bridge([1, 2], ["a", "b"], torque_constants=[0.5, 2.0])
    b.readings({1: state(1, 0.0), 2: state(2, 0.0)})
    message = b.joint_state(0)
    assert message is not None and message.effort == [pytest.approx(0.2), pytest.approx(0.8)]  # 0.4 A each


@pytest.mark.parametrize(
    ("constants", "why"), [([1.0], "1 torque constants for 2 motors"), ([1.0, 0.0], "torque constant 0.0")]
)
def test_a_wrong_torque_constant_is_refused(constants: list[float], why: str) -> None:
    with pytest.raises(ValueError, match=why):
        Bridge([1, 2], ["a", "b"], torque_constants=constants)


def test_a_signed_speed_is_published_as_read() -> None:
    """The library's signed speed (speed feedback's direction byte or the position trend) is
    what joint_states shows, with no second sign applied (-45 RPM is -45 RPM)."""
    b = Bridge([1], ["a"])
    b.readings({1: state(1, 10.0, speed=-45.0, signed=True)})
    message = b.joint_state(0)
    assert message is not None and message.velocity == [pytest.approx(-45 * 2 * math.pi / 60)]
    b.readings({1: state(1, 20.0, speed=-45.0, signed=True)})  # the position went up: no matter, the reading is signed
    message = b.joint_state(0)
    assert message is not None and message.velocity == [pytest.approx(-45 * 2 * math.pi / 60)]


def test_no_joint_state_when_none_answered() -> None:
    b = Bridge([1], ["a"])
    b.readings({})
    assert b.joint_state(0) is None
    assert b.joints[0].failures == 1


def test_diagnostics_per_motor_and_bus() -> None:
    b = Bridge([1, 2], ["a", "b"])
    b.readings({1: state(1, 0.0), 2: NoAnswer("request_position", 2, 9600, 3)})
    array = b.diagnostics(0, "nurimc/arm", "sim:// @ 9600 bps", {"requests": 7})
    by_name = {s.name: s for s in array.status}
    assert by_name["nurimc/arm: a"].level == msgs.DIAGNOSTIC_OK
    assert by_name["nurimc/arm: b"].level == msgs.DIAGNOSTIC_ERROR
    assert "no answer" in by_name["nurimc/arm: b"].message.lower()
    values = {kv.key: kv.value for kv in by_name["nurimc/arm: bus"].values}
    assert values["requests"] == "7" and values["estop_latched"] == "false"
    assert by_name["nurimc/arm: bus"].level == msgs.DIAGNOSTIC_WARN
    b.readings({1: state(1, 0.0), 2: state(2, 0.0)})
    b.readings({1: state(1, 0.0), 2: NoAnswer("request_position", 2, 9600, 3)})
    b.readings({1: state(1, 0.0), 2: NoAnswer("request_position", 2, 9600, 3)})
    status = {s.name: s for s in b.diagnostics(0, "p", "h", {}).status}["p: b"]
    assert status.message.startswith("stale (2 readings missed; joint_states keeps the last position")
    values = {kv.key: kv.value for kv in status.values}
    assert values["stale"] == "true" and values["missed_in_a_row"] == "2" and values["failed_reads"] == "3"


@pytest.mark.parametrize(
    ("options", "why"),
    [({"command_timeout": -1}, "command timeout"), ({"move_velocity": 0.0}, "move velocity")],
)
def test_bad_bridge_options(options: dict[str, Any], why: str) -> None:
    with pytest.raises(ValueError, match=why):
        Bridge([1], ["a"], **options)


def test_names() -> None:
    assert namespace("") == namespace("/") == "/"
    assert namespace("arm") == namespace("/arm") == "/arm"
    assert namespace("/robot/left_arm2") == "/robot/left_arm2"
    assert topic("/", "joint_states") == "/joint_states"
    assert topic("/arm", "joint_states") == "/arm/joint_states"
    assert topic("/arm", "/diagnostics") == "/diagnostics"
    assert dds_topic("/arm/joint_states") == "rt/arm/joint_states"
    for bad in ("/arm/", "/a//b", "/2arm", "/a-b", "/a b"):
        with pytest.raises(NameError_):
            namespace(bad)
    assert joint_names(None, [3, 1]) == ["motor_3", "motor_1"]
    assert joint_names("x, y", [3, 1]) == ["x", "y"]
    for bad_names in ("x", "x,x", "x,"):
        with pytest.raises(NameError_):
            joint_names(bad_names, [3, 1])


def test_domain_id() -> None:
    assert domain_id({}) == 0
    assert domain_id({"ROS_DOMAIN_ID": " 42 "}) == 42
    for bad in ("x", "-1", "233"):
        with pytest.raises(ValueError, match="ROS_DOMAIN_ID"):
            domain_id({"ROS_DOMAIN_ID": bad})


def test_units() -> None:
    assert convert.deg_to_rad(180) == pytest.approx(math.pi)
    assert convert.rad_to_deg(math.pi / 2) == pytest.approx(90)
    assert convert.rad_s_to_rpm(2 * math.pi) == pytest.approx(60)
    assert convert.rpm_to_rad_s(60) == pytest.approx(2 * math.pi)
