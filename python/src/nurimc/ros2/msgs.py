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


# -- ros2msg definitions (MCAP schemas: the message's own text, then each dependency) -------

_OWN = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/Bool": "bool data\n",
    "std_msgs/msg/MultiArrayDimension": "string label\nuint32 size\nuint32 stride\n",
    "std_msgs/msg/MultiArrayLayout": "MultiArrayDimension[] dim\nuint32 data_offset\n",
    "std_msgs/msg/Float64MultiArray": "MultiArrayLayout layout\nfloat64[] data\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
    ),
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n"
        "byte level\nstring name\nstring message\nstring hardware_id\nKeyValue[] values\n"
    ),
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header\nDiagnosticStatus[] status\n",
    "nurimc_msgs/msg/Frame": (
        "# One whole RS485 frame: tx = host to bus, rx = bus to host.\n"
        "builtin_interfaces/Time stamp\nstring direction\nuint8 id\nstring name\nuint8[] data\n"
        "# bytes on this direction that formed no frame since the previous frame (noise)\n"
        "uint32 dropped_before\n"
    ),
    # the mobile base's types (base_msgs.py), for MCAP recordings of odom, /tf and cmd_vel
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Pose": "Point position\nQuaternion orientation\n",
    "geometry_msgs/msg/PoseWithCovariance": "Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/msg/Twist": "Vector3 linear\nVector3 angular\n",
    "geometry_msgs/msg/TwistStamped": "std_msgs/Header header\nTwist twist\n",
    "geometry_msgs/msg/TwistWithCovariance": "Twist twist\nfloat64[36] covariance\n",
    "geometry_msgs/msg/Transform": "Vector3 translation\nQuaternion rotation\n",
    "geometry_msgs/msg/TransformStamped": "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "nav_msgs/msg/Odometry": (
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
        "geometry_msgs/TwistWithCovariance twist\n"
    ),
}

_HEADER = ["std_msgs/msg/Header", "builtin_interfaces/msg/Time"]
_POSE = ["geometry_msgs/msg/Pose", "geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion"]
_TWIST = ["geometry_msgs/msg/Twist", "geometry_msgs/msg/Vector3"]
_TRANSFORM = ["geometry_msgs/msg/Transform", "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Quaternion"]

_DEPENDS = {
    "geometry_msgs/msg/Pose": _POSE[1:],
    "geometry_msgs/msg/PoseWithCovariance": _POSE,
    "geometry_msgs/msg/Twist": _TWIST[1:],
    "geometry_msgs/msg/TwistStamped": [*_HEADER, *_TWIST],
    "geometry_msgs/msg/TwistWithCovariance": _TWIST,
    "geometry_msgs/msg/Transform": _TRANSFORM[1:],
    "geometry_msgs/msg/TransformStamped": [*_HEADER, *_TRANSFORM],
    "tf2_msgs/msg/TFMessage": ["geometry_msgs/msg/TransformStamped", *_HEADER, *_TRANSFORM],
    "nav_msgs/msg/Odometry": [
        *_HEADER,
        "geometry_msgs/msg/PoseWithCovariance",
        *_POSE,
        "geometry_msgs/msg/TwistWithCovariance",
        *_TWIST,
    ],
    "std_msgs/msg/Header": ["builtin_interfaces/msg/Time"],
    "std_msgs/msg/MultiArrayLayout": ["std_msgs/msg/MultiArrayDimension"],
    "std_msgs/msg/Float64MultiArray": ["std_msgs/msg/MultiArrayLayout", "std_msgs/msg/MultiArrayDimension"],
    "sensor_msgs/msg/JointState": ["std_msgs/msg/Header", "builtin_interfaces/msg/Time"],
    "diagnostic_msgs/msg/DiagnosticStatus": ["diagnostic_msgs/msg/KeyValue"],
    "diagnostic_msgs/msg/DiagnosticArray": [
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "diagnostic_msgs/msg/DiagnosticStatus",
        "diagnostic_msgs/msg/KeyValue",
    ],
    "nurimc_msgs/msg/Frame": ["builtin_interfaces/msg/Time"],
}

_SEPARATOR = "=" * 80 + "\n"


def definition(ros_type: str) -> str:
    """The `ros2msg` schema text of a message type: its fields, then `MSG: pkg/Type` sections."""
    text = _OWN[ros_type]
    for dependency in _DEPENDS.get(ros_type, []):
        package, _, name = dependency.split("/")
        text += f"{_SEPARATOR}MSG: {package}/{name}\n{_OWN[dependency]}"
    return text


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
