"""The request and response types of the bridge's ROS 2 services, as DDS types (as msgs.py does for messages).

Each class is a Cyclone DDS IdlStruct named as rosidl names the DDS type of a service's request
or response (`<pkg>::srv::dds_::<Service>_Request_`), its fields those of the `.srv` in order,
with the IDL types rosidl maps them to (byte -> octet, T[<=1] -> sequence<T, 1>, an empty request
gets rosidl's `uint8 structure_needs_at_least_one_member`). So the CDR bytes are those a ROS 2
node sends (tests compare them with rclpy's `serialize_message`, and the type hashes with those
the rcl_interfaces wheels ship).

- rcl_interfaces: the six parameter services every ROS 2 node offers (list, get, set, set
  atomically, describe, get types) and their messages.
- std_srvs/srv/Trigger: the estop service, a stock type rclpy users have without building ours.
- nurimc_msgs/srv: ReadSetting, WriteSetting, ResetPosition; their `.srv` files are in the ROS 2
  interface package `ros2/nurimc_msgs/` at the top of the repository (colcon builds it).
"""

# No `from __future__ import annotations`: Cyclone DDS reads the field types at run time.
import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import byte, float64, int64, uint8, uint64

from .typehash import ARRAY, BOUNDED_SEQUENCE, NESTED, SCALARS, ros_name, type_description

if TYPE_CHECKING:  # to the type checker a sequence field is the list it holds
    sequence = list
else:
    from cyclonedds.idl.types import sequence

# -- rcl_interfaces/msg/ParameterType -----------------------------------------------------------

PARAMETER_NOT_SET = 0
PARAMETER_BOOL = 1
PARAMETER_INTEGER = 2
PARAMETER_DOUBLE = 3
PARAMETER_STRING = 4
PARAMETER_BYTE_ARRAY = 5
PARAMETER_BOOL_ARRAY = 6
PARAMETER_INTEGER_ARRAY = 7
PARAMETER_DOUBLE_ARRAY = 8
PARAMETER_STRING_ARRAY = 9

TYPE_NAMES = {
    PARAMETER_NOT_SET: "not set",
    PARAMETER_BOOL: "bool",
    PARAMETER_INTEGER: "integer",
    PARAMETER_DOUBLE: "double",
    PARAMETER_STRING: "string",
    PARAMETER_BYTE_ARRAY: "byte array",
    PARAMETER_BOOL_ARRAY: "bool array",
    PARAMETER_INTEGER_ARRAY: "integer array",
    PARAMETER_DOUBLE_ARRAY: "double array",
    PARAMETER_STRING_ARRAY: "string array",
}

# -- rcl_interfaces/msg -----------------------------------------------------------------------


@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: uint8 = PARAMETER_NOT_SET
    bool_value: bool = False
    integer_value: int64 = 0
    double_value: float64 = 0.0
    string_value: str = ""
    byte_array_value: sequence[byte] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[int64] = field(default_factory=list)
    double_array_value: sequence[float64] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)


@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@dataclass
class FloatingPointRange(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float64 = 0.0
    to_value: float64 = 0.0
    step: float64 = 0.0


@dataclass
class IntegerRange(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: int64 = 0
    to_value: int64 = 0
    step: uint64 = 0


if TYPE_CHECKING:
    FloatingPointRangeAtMostOne = list[FloatingPointRange]
    IntegerRangeAtMostOne = list[IntegerRange]
else:  # rosidl's bounded sequence T[<=1]: the same bytes as T[], another type hash
    FloatingPointRangeAtMostOne = sequence[FloatingPointRange, 1]
    IntegerRangeAtMostOne = sequence[IntegerRange, 1]


@dataclass
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str = ""
    type: uint8 = PARAMETER_NOT_SET
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    floating_point_range: FloatingPointRangeAtMostOne = field(default_factory=list)  # FloatingPointRange[<=1]
    integer_range: IntegerRangeAtMostOne = field(default_factory=list)  # IntegerRange[<=1]


@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool = False
    reason: str = ""


@dataclass
class ListParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: sequence[str] = field(default_factory=list)
    prefixes: sequence[str] = field(default_factory=list)


# -- rcl_interfaces/srv -----------------------------------------------------------------------

DEPTH_RECURSIVE = 0  # ListParameters: every level


@dataclass
class ListParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Request_"):
    prefixes: sequence[str] = field(default_factory=list)
    depth: uint64 = DEPTH_RECURSIVE


@dataclass
class ListParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::ListParameters_Response_"):
    result: ListParametersResult = field(default_factory=ListParametersResult)


@dataclass
class GetParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Request_"):
    names: sequence[str] = field(default_factory=list)


@dataclass
class GetParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Response_"):
    values: sequence[ParameterValue] = field(default_factory=list)


@dataclass
class SetParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Request_"):
    parameters: sequence[Parameter] = field(default_factory=list)


@dataclass
class SetParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Response_"):
    results: sequence[SetParametersResult] = field(default_factory=list)


@dataclass
class SetParametersAtomically_Request(
    IdlStruct, typename="rcl_interfaces::srv::dds_::SetParametersAtomically_Request_"
):
    parameters: sequence[Parameter] = field(default_factory=list)


@dataclass
class SetParametersAtomically_Response(
    IdlStruct, typename="rcl_interfaces::srv::dds_::SetParametersAtomically_Response_"
):
    result: SetParametersResult = field(default_factory=SetParametersResult)


@dataclass
class DescribeParameters_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Request_"):
    names: sequence[str] = field(default_factory=list)


@dataclass
class DescribeParameters_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::DescribeParameters_Response_"):
    descriptors: sequence[ParameterDescriptor] = field(default_factory=list)


@dataclass
class GetParameterTypes_Request(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameterTypes_Request_"):
    names: sequence[str] = field(default_factory=list)


@dataclass
class GetParameterTypes_Response(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameterTypes_Response_"):
    types: sequence[uint8] = field(default_factory=list)


# -- std_srvs/srv/Trigger ---------------------------------------------------------------------


@dataclass
class Trigger_Request(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    structure_needs_at_least_one_member: uint8 = 0  # rosidl's member of an empty structure


@dataclass
class Trigger_Response(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    success: bool = False
    message: str = ""


# -- nurimc_msgs/srv (ros2/nurimc_msgs/srv/*.srv) ---------------------------------------------


@dataclass
class ReadSetting_Request(IdlStruct, typename="nurimc_msgs::srv::dds_::ReadSetting_Request_"):
    id: uint8 = 0
    name: str = ""


@dataclass
class ReadSetting_Response(IdlStruct, typename="nurimc_msgs::srv::dds_::ReadSetting_Response_"):
    success: bool = False
    message: str = ""
    value: str = ""


@dataclass
class WriteSetting_Request(IdlStruct, typename="nurimc_msgs::srv::dds_::WriteSetting_Request_"):
    id: uint8 = 0
    name: str = ""
    value: str = ""


@dataclass
class WriteSetting_Response(IdlStruct, typename="nurimc_msgs::srv::dds_::WriteSetting_Response_"):
    success: bool = False
    message: str = ""
    value_read_back: str = ""


@dataclass
class ResetPosition_Request(IdlStruct, typename="nurimc_msgs::srv::dds_::ResetPosition_Request_"):
    id: uint8 = 0  # 0: every motor of the bridge


@dataclass
class ResetPosition_Response(IdlStruct, typename="nurimc_msgs::srv::dds_::ResetPosition_Response_"):
    success: bool = False
    message: str = ""


#: ROS 2 service type ("pkg/srv/Name") -> (request type, response type)
SERVICE_TYPES: dict[str, tuple[type[IdlStruct], type[IdlStruct]]] = {
    "rcl_interfaces/srv/ListParameters": (ListParameters_Request, ListParameters_Response),
    "rcl_interfaces/srv/GetParameters": (GetParameters_Request, GetParameters_Response),
    "rcl_interfaces/srv/SetParameters": (SetParameters_Request, SetParameters_Response),
    "rcl_interfaces/srv/SetParametersAtomically": (SetParametersAtomically_Request, SetParametersAtomically_Response),
    "rcl_interfaces/srv/DescribeParameters": (DescribeParameters_Request, DescribeParameters_Response),
    "rcl_interfaces/srv/GetParameterTypes": (GetParameterTypes_Request, GetParameterTypes_Response),
    "std_srvs/srv/Trigger": (Trigger_Request, Trigger_Response),
    "nurimc_msgs/srv/ReadSetting": (ReadSetting_Request, ReadSetting_Response),
    "nurimc_msgs/srv/WriteSetting": (WriteSetting_Request, WriteSetting_Response),
    "nurimc_msgs/srv/ResetPosition": (ResetPosition_Request, ResetPosition_Response),
}


# -- the type hash of a service type (REP 2011), for the endpoints' USER_DATA ----------------------


def _nested(name: str, type_name: str, type_id: int = 1, capacity: int = 0) -> dict[str, Any]:
    kind = {"type_id": type_id, "capacity": capacity, "string_capacity": 0, "nested_type_name": type_name}
    return {"name": name, "type": kind}


def service_type_description(srv_type: str) -> dict[str, Any]:
    """The hashed form of a service's type description: request_message, response_message and
    event_message (`<Service>_Event`: service_msgs/ServiceEventInfo info, Request[<=1] request,
    Response[<=1] response), then every type they refer to, sorted by name."""
    request, response = SERVICE_TYPES[srv_type]
    referenced: dict[str, dict[str, Any]] = {}
    for part in (request, response):
        described = type_description(part)
        referenced[ros_name(part)] = described["type_description"]
        for nested in described["referenced_type_descriptions"]:
            referenced[nested["type_name"]] = nested
    bounded_one = BOUNDED_SEQUENCE + NESTED
    referenced[f"{srv_type}_Event"] = {
        "type_name": f"{srv_type}_Event",
        "fields": [
            _nested("info", "service_msgs/msg/ServiceEventInfo"),
            _nested("request", f"{srv_type}_Request", bounded_one, 1),
            _nested("response", f"{srv_type}_Response", bounded_one, 1),
        ],
    }
    referenced["service_msgs/msg/ServiceEventInfo"] = {
        "type_name": "service_msgs/msg/ServiceEventInfo",
        "fields": [
            _nested("event_type", "", SCALARS["uint8"]),
            _nested("stamp", "builtin_interfaces/msg/Time"),
            _nested("client_gid", "", ARRAY + SCALARS["uint8"], 16),
            _nested("sequence_number", "", SCALARS["int64"]),
        ],
    }
    referenced["builtin_interfaces/msg/Time"] = {
        "type_name": "builtin_interfaces/msg/Time",
        "fields": [_nested("sec", "", SCALARS["int32"]), _nested("nanosec", "", SCALARS["uint32"])],
    }
    own = {
        "type_name": srv_type,
        "fields": [
            _nested("request_message", f"{srv_type}_Request"),
            _nested("response_message", f"{srv_type}_Response"),
            _nested("event_message", f"{srv_type}_Event"),
        ],
    }
    return {"type_description": own, "referenced_type_descriptions": [referenced[n] for n in sorted(referenced)]}


def service_type_hash(srv_type: str) -> str:
    """RIHS01_<64 hex digits> of a service type ("rcl_interfaces/srv/GetParameters")."""
    text = json.dumps(service_type_description(srv_type), separators=(", ", ": "))
    return "RIHS01_" + hashlib.sha256(text.encode("utf-8")).hexdigest()
