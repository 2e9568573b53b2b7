"""The ROS 2 message types of a mobile base, as DDS types (geometry_msgs, nav_msgs, tf2_msgs).

Named and laid out as ROS 2 maps them (`<pkg>::msg::dds_::<Type>_`, float64[36] -> double[36]), so
the CDR bytes are a ROS 2 node's. Without Cyclone DDS they are plain dataclasses (see msgs.py).
"""

# No `from __future__ import annotations`: Cyclone DDS reads the field types at run time.
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

try:
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl.types import float64
except ImportError:  # no DDS stack: plain dataclasses written by recording/cdr.py
    from ..recording.cdr import IdlStruct, float64  # type: ignore[assignment]

from .msgs import Header

if TYPE_CHECKING:  # to the type checker a sequence or array field is the list it holds
    sequence = list
    Covariance = list[float]
else:
    try:
        from cyclonedds.idl.types import array, sequence

        Covariance = array[float64, 36]  # row-major 6x6
    except ImportError:  # no DDS stack: plain dataclasses written by recording/cdr.py
        sequence = list
        Covariance = list


def _zeros() -> list[float]:
    return [0.0] * 36


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TwistStamped_"):
    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: Covariance = field(default_factory=_zeros)


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: Covariance = field(default_factory=_zeros)


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped] = field(default_factory=list)
