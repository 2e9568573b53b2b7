"""An independent ROS 2 participant for the tests: its own type definitions, its own DDS set-up.

Nothing here comes from nurimc: the types are written from the ROS 2 message definitions
(`<pkg>::msg::dds_::<Type>_`), topics are named `rt/<name>` and the QoS is ROS 2's default,
so what it exchanges with the bridge is what a ROS 2 node would.
"""

# Cyclone DDS IDL annotations (sequence[float64], ...) are run-time type markers its stubs do not
# model as generics.
# mypy: disable-error-code="type-arg,arg-type"
# No `from __future__ import annotations`: Cyclone DDS reads the field types at run time.
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import byte, float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str
    size: uint32
    stride: uint32


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension]
    data_offset: uint32


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout
    data: sequence[float64]


@dataclass
class Bool(IdlStruct, typename="std_msgs::msg::dds_::Bool_"):
    data: bool


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: byte
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header
    status: sequence[DiagnosticStatus]


def ros_default_qos() -> Qos:
    return Qos(
        Policy.Reliability.Reliable(duration(milliseconds=100)),
        Policy.Durability.Volatile,
        Policy.History.KeepLast(10),
    )


@dataclass
class Subscription:
    reader: Any
    samples: list[Any] = field(default_factory=list)

    def poll(self) -> list[Any]:
        self.samples.extend(s for s in self.reader.take(N=256) if isinstance(s, IdlStruct))
        return self.samples

    def wait_for(self, test: Callable[[Any], bool], timeout: float, what: str) -> Any:
        """The first sample from now on that passes `test` (AssertionError naming `what` if none)."""
        start = len(self.poll())
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for sample in self.poll()[start:]:
                if test(sample):
                    return sample
            start = len(self.samples)
            time.sleep(0.01)
        last = self.samples[-1] if self.samples else None
        raise AssertionError(f"no {what} within {timeout} s; last sample: {last}")


class Peer:
    def __init__(self) -> None:
        self.participant = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
        self.topics: dict[str, Topic[Any]] = {}

    def _topic(self, name: str, data_type: type[IdlStruct]) -> Topic[Any]:
        if name not in self.topics:
            self.topics[name] = Topic(self.participant, "rt" + name, data_type, qos=ros_default_qos())
        return self.topics[name]

    def subscribe(self, name: str, data_type: type[IdlStruct]) -> Subscription:
        return Subscription(DataReader(self.participant, self._topic(name, data_type), qos=ros_default_qos()))

    def publisher(self, name: str, data_type: type[IdlStruct]) -> DataWriter[Any]:
        return DataWriter(self.participant, self._topic(name, data_type), qos=ros_default_qos())

    def close(self) -> None:
        self.participant.__del__()


def command(values: list[float]) -> Float64MultiArray:
    return Float64MultiArray(MultiArrayLayout([], 0), values)


# -- /tf (tf2_msgs has no PyPI wheel, so the real rclpy nodes cannot subscribe it: we do) ----------


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header
    twist: Twist
