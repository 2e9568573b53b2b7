"""ROS 2 message types as DDS types, plus our raw-frame type, and their `ros2msg` definitions.

Each class is a Cyclone DDS IdlStruct named as ROS 2 names the DDS type of a message
(`<pkg>::msg::dds_::<Type>_`); its fields are those of the message, in order, with the IDL
types ROS 2 maps them to (float64[] -> sequence<double>, byte -> octet, ...). So the CDR bytes
are those a ROS 2 node sends (tests compare them with rosbags'). `DEFINITIONS` holds each
message's definition in the `ros2msg` text format (with its dependencies), for MCAP schemas.

Without Cyclone DDS installed the classes are plain dataclasses with the same names and fields,
serialised to the same bytes by recording/cdr.py: `nurimc record` needs only the mcap package.
"""

# No `from __future__ import annotations`: Cyclone DDS reads the field types at run time.
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from .definitions import definition as definition  # the schema texts, read by the recorder too

try:
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl.types import byte, float64, int32, uint8, uint32
except ImportError:  # no DDS stack: plain dataclasses written by recording/cdr.py (`record` needs only mcap)
    from ..recording.cdr import IdlStruct, byte, float64, int32, uint8, uint32  # type: ignore[assignment]

if TYPE_CHECKING:  # to the type checker a sequence field is the list it holds
    sequence = list
else:
    try:
        from cyclonedds.idl.types import sequence
    except ImportError:
        from ..recording.cdr import sequence

# -- builtin_interfaces -------------------------------------------------------------------


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0

    @classmethod
    def from_ns(cls, ns: int) -> "Time":
        return cls(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    def to_ns(self) -> int:
        return self.sec * 1_000_000_000 + self.nanosec


# -- std_msgs -------------------------------------------------------------------------------


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class Bool(IdlStruct, typename="std_msgs::msg::dds_::Bool_"):
    data: bool = False


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: uint32 = 0
    stride: uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[float64] = field(default_factory=list)


# -- sensor_msgs ----------------------------------------------------------------------------


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[float64] = field(default_factory=list)
    velocity: sequence[float64] = field(default_factory=list)
    effort: sequence[float64] = field(default_factory=list)


# -- diagnostic_msgs ------------------------------------------------------------------------

DIAGNOSTIC_OK, DIAGNOSTIC_WARN, DIAGNOSTIC_ERROR, DIAGNOSTIC_STALE = 0, 1, 2, 3


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: byte = DIAGNOSTIC_OK  # ROS `byte` is IDL `octet`
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header = field(default_factory=Header)
    status: sequence[DiagnosticStatus] = field(default_factory=list)


# -- ours: one frame of the RS485 bus -------------------------------------------------------


@dataclass
class Frame(IdlStruct, typename="nurimc_msgs::msg::dds_::Frame_"):
    """A whole frame seen on the bus: what the host sent ("tx") or received ("rx")."""

    stamp: Time = field(default_factory=Time)
    direction: str = ""
    id: uint8 = 0
    name: str = ""
    data: sequence[uint8] = field(default_factory=list)
    dropped_before: uint32 = 0


#: ROS 2 type name ("pkg/msg/Type") -> the DDS type
TYPES: dict[str, type[IdlStruct]] = {
    "builtin_interfaces/msg/Time": Time,
    "std_msgs/msg/Header": Header,
    "std_msgs/msg/Bool": Bool,
    "std_msgs/msg/MultiArrayDimension": MultiArrayDimension,
    "std_msgs/msg/MultiArrayLayout": MultiArrayLayout,
    "std_msgs/msg/Float64MultiArray": Float64MultiArray,
    "sensor_msgs/msg/JointState": JointState,
    "diagnostic_msgs/msg/KeyValue": KeyValue,
    "diagnostic_msgs/msg/DiagnosticStatus": DiagnosticStatus,
    "diagnostic_msgs/msg/DiagnosticArray": DiagnosticArray,
    "nurimc_msgs/msg/Frame": Frame,
}


def ros_type_of(message: IdlStruct) -> str:
    """ "sensor_msgs::msg::dds_::JointState_" -> "sensor_msgs/msg/JointState"."""
    package, _, _, name = type(message).__idl_typename__.split("::")
    return f"{package}/msg/{name.rstrip('_')}"
