"""The `ros2msg` schema text of every message type we write: plain data, no DDS stack, so the
CDR writer (recording/cdr.py) and the DDS types (msgs.py) both read it without importing each
other."""

from __future__ import annotations

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
