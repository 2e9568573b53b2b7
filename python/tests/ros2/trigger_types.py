"""std_srvs/Trigger with rmw_cyclonedds_cpp's in-band request header, for test_rtps.py (the plain
types are nurimc.ros2.interfaces'; no `from __future__ import annotations`: Cyclone DDS reads the
field types at run time)."""

from dataclasses import dataclass

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int64, uint8, uint64


@dataclass
class CycloneTriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    client: uint64 = 0  # rmw_cyclonedds_cpp's header: the client's id, the request's number
    number: int64 = 0
    structure_needs_at_least_one_member: uint8 = 0


@dataclass
class CycloneTriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    client: uint64 = 0
    number: int64 = 0
    success: bool = False
    message: str = ""
