"""The bridge node's ROS 2 services, transport-independent: what runs when a request arrives
(docs/ros2.md, "Parameters and services").

`bridge_services(node, node_name, namespace)` lists every service of the node as a ServiceSpec:
its full ROS name, its type, the request and response DDS types (interfaces.py) and the handler,
request object -> response object. The transport (the bridge's own RTPS endpoints, ros2/rtps/)
calls the handler on its own thread; a handler may wait for the bus service for a bounded time
and never raises: every error becomes the response's success/reason fields.

- `<node>/list_parameters` ... `get_parameter_types`: the six rcl_interfaces parameter
  services, as rclpy's parameter clients (and `ros2 param`) call them (parameters.py).
- `<node>/read_setting`, `write_setting`, `reset_position`: our nurimc_msgs services (their .srv
  files: ros2/nurimc_msgs/ at the top of the repository, a package colcon builds).
- `<node>/estop`: std_srvs/srv/Trigger, the bridge's one emergency stop with its read-back.

Every bus access is a job of the bridge's BusService: no stop of the bridge is needed, and an
emergency stop wins over a job queued before it. While the port is lost a call answers at once
with the outage (success false, the message says the port is lost), never with a timeout.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from cyclonedds.idl import IdlStruct

from ..cli.zero_cmd import ZERO_WAIT, zero_here
from ..procedures.motor import MotorState
from ..procedures.settings import SETTINGS, setting
from ..procedures.stop import StopResult
from ..protocol.host import STOP_VERIFY
from ..service.core import COMMAND
from . import interfaces as i
from .names import topic
from .parameters import APPLY_TIMEOUT, BridgeParameters, Refusal, bus_job, port_lost

if TYPE_CHECKING:
    from .node import BridgeNode

ESTOP_WAIT = STOP_VERIFY + 3.0  # s the estop service waits for the stop and its read-back


@dataclass(frozen=True)
class ServiceSpec:
    name: str  # full ROS service name, e.g. "/arm/nurimc/get_parameters"
    srv_type: str  # "rcl_interfaces/srv/GetParameters"
    request: type[IdlStruct]  # typename "rcl_interfaces::srv::dds_::GetParameters_Request_"
    response: type[IdlStruct]  # typename "rcl_interfaces::srv::dds_::GetParameters_Response_"
    handler: Callable[[Any], Any]  # request object -> response object. Called on a transport thread;
    # may block on the bus service (bounded time); must never raise
    # (errors become the response's success/reason fields).


def bridge_services(node: BridgeNode, node_name: str, namespace: str) -> list[ServiceSpec]:
    """Every service of the bridge node `namespace/node_name`."""
    base = topic(namespace, node_name)
    parameters = BridgeParameters(node, base)
    settings = ControllerServices(node)
    handlers: list[tuple[str, str, Callable[[Any], Any]]] = [
        ("list_parameters", "rcl_interfaces/srv/ListParameters", parameters.list_parameters),
        ("get_parameters", "rcl_interfaces/srv/GetParameters", parameters.get_parameters),
        ("set_parameters", "rcl_interfaces/srv/SetParameters", parameters.set_parameters),
        (
            "set_parameters_atomically",
            "rcl_interfaces/srv/SetParametersAtomically",
            parameters.set_parameters_atomically,
        ),
        ("describe_parameters", "rcl_interfaces/srv/DescribeParameters", parameters.describe_parameters),
        ("get_parameter_types", "rcl_interfaces/srv/GetParameterTypes", parameters.get_parameter_types),
        ("read_setting", "nurimc_msgs/srv/ReadSetting", settings.read_setting),
        ("write_setting", "nurimc_msgs/srv/WriteSetting", settings.write_setting),
        ("reset_position", "nurimc_msgs/srv/ResetPosition", settings.reset_position),
        ("estop", "std_srvs/srv/Trigger", settings.estop),
    ]
    specs = []
    for name, srv_type, handler in handlers:
        request, response = i.SERVICE_TYPES[srv_type]
        specs.append(ServiceSpec(f"{base}/{name}", srv_type, request, response, guarded(handler, response, node)))
    return specs


def guarded(handler: Callable[[Any], Any], response: type[IdlStruct], node: BridgeNode) -> Callable[[Any], Any]:
    """The handler, never raising: an unexpected error (a bug) is logged and answered as a failure
    in the response's own fields (success/successful false, the reason in message/reason)."""

    def handle(request: Any) -> Any:
        try:
            return handler(request)
        except Exception as error:
            text = f"internal error in the bridge: {type(error).__name__}: {error}"
            node._log(f"service {response.__name__.removesuffix('_Response')}: {text}")
            return failure(response, request, text)

    return handle


def failure(response: type[IdlStruct], request: Any, text: str) -> Any:
    """A response saying `text` failed, in whichever fields the type has: one entry per name or
    parameter asked where the response has a list (NOT_SET values and types, refused results)."""
    answer: Any = response()
    names = list(getattr(request, "names", []))
    if hasattr(answer, "success"):
        answer.success, answer.message = False, text
    elif hasattr(answer, "result") and isinstance(answer.result, i.SetParametersResult):
        answer.result = i.SetParametersResult(False, text)
    elif hasattr(answer, "results"):
        answer.results = [i.SetParametersResult(False, text) for _ in getattr(request, "parameters", [])]
    elif hasattr(answer, "values"):
        answer.values = [i.ParameterValue() for _ in names]
    elif hasattr(answer, "types"):
        answer.types = [i.PARAMETER_NOT_SET for _ in names]
    elif hasattr(answer, "descriptors"):
        answer.descriptors = [i.ParameterDescriptor(name=n, description=text) for n in names]
    return answer


class ControllerServices:
    """read_setting, write_setting, reset_position (nurimc_msgs) and estop (std_srvs/Trigger)."""

    def __init__(self, node: BridgeNode) -> None:
        self.node = node
        self.parameters = BridgeParameters(node)

    def _motor(self, device_id: int) -> int:
        if device_id not in self.node.motors:
            ids = ", ".join(map(str, self.node.motors))
            raise Refusal(f"ID {device_id} is not one of the bridge's motors ({ids}); nothing was sent")
        return device_id

    @staticmethod
    def _named(name: str, writing: bool = False) -> Any:
        key = name.strip().lower().replace("_", "-")
        if key in ("id", "baud"):
            raise Refusal(
                f"{key} cannot change while the bridge runs (it talks to the motors by ID and rate): stop the "
                f"bridge, run `nurimc set {key} ...`, restart it with --ids/--baud"
            )
        if key not in SETTINGS:
            raise Refusal(f"unknown setting {name!r}; settings: {', '.join(SETTINGS)}")
        s = setting(key)
        if writing and s.command is None:
            raise Refusal(f"{s.name} is read-only (the controller's own)")
        return s

    def read_setting(self, request: i.ReadSetting_Request) -> i.ReadSetting_Response:
        """A fresh read of one setting from the controller, in physical units (as `nurimc get`)."""
        try:
            device_id = self._motor(int(request.id))
            s = self._named(request.name)
            value = self.parameters.read_settings(device_id, [s])[s.name]
        except Refusal as error:
            return i.ReadSetting_Response(False, str(error), "")
        text = _text(value)
        return i.ReadSetting_Response(True, f"ID {device_id}: {s.name} = {text}{_unit(s)}", text)

    def write_setting(self, request: i.WriteSetting_Request) -> i.WriteSetting_Response:
        """Write one setting (physical units: 12.5, 300us, cw, on), then read it back: success only
        when the value read back is the value written."""
        try:
            device_id = self._motor(int(request.id))
            s = self._named(request.name, writing=True)
            value = request.value.strip()
            if not value:
                raise Refusal(f"{s.name}: give a value ({s.describe_range()})")
            read = self.parameters.write_setting(device_id, s, value)
        except Refusal as error:
            return i.WriteSetting_Response(False, str(error), "")
        text = _text(read)
        return i.WriteSetting_Response(True, f"ID {device_id}: {s.name} = {text}{_unit(s)} (read back)", text)

    def reset_position(self, request: i.ResetPosition_Request) -> i.ResetPosition_Response:
        """The position reset (`nurimc set-zero`): the present position becomes 0 and the multi-turn
        count starts again; read back. ID 0: every motor of the bridge."""
        lines: list[str] = []
        good = True
        try:
            ids = list(self.node.motors) if request.id == 0 else [self._motor(int(request.id))]
            for device_id in ids:
                procedures = self.node.motors[device_id].procedures
                state = bus_job(self.node, zero_here(self.node.bus.core, procedures), COMMAND)
                self._take_reading(device_id, state)
                if abs(state.device_position) < 1.0:
                    lines.append(f"ID {device_id}: 0° (read back)")
                else:
                    good = False
                    lines.append(
                        f"ID {device_id}: reads {state.device_position:.2f}° {ZERO_WAIT:g} s after the reset, not 0°"
                    )
        except Refusal as error:
            return i.ResetPosition_Response(False, "; ".join([*lines, str(error)]))
        return i.ResetPosition_Response(good, "; ".join(lines))

    def _take_reading(self, device_id: int, state: MotorState) -> None:
        """The reading after a reset becomes the joint's latest at once (on the node's thread), so a
        position command that comes before the next poll already means the new zero."""
        joint = next(j for j in self.node.bridge.joints if j.id == device_id)

        def take() -> None:
            joint.state = state

        with contextlib.suppress(concurrent.futures.TimeoutError):  # the next poll brings it anyway
            self.node.run_on_bus_thread(take, APPLY_TIMEOUT)

    def estop(self, request: i.Trigger_Request) -> i.Trigger_Response:
        """The bridge's estop, as `true` on its estop topic: every queued command dropped, control off
        by the bus service's one emergency stop, read back per motor, latched (commands refused until
        `false` on estop). Success only when every motor read back control off."""
        node = self.node
        lost = port_lost(node)
        if lost is not None:  # latched all the same: control off goes first when the port returns
            node._push("estop", True)
            return i.Trigger_Response(
                False, f"{lost}; the estop is latched and control off is sent first when the port returns"
            )
        if node._thread is None or not node._thread.is_alive():
            return i.Trigger_Response(False, "the bridge is not running; nothing was sent")
        done = threading.Event()
        results: list[StopResult] = []

        def told(result: StopResult) -> None:
            results.append(result)
            done.set()

        node.on_stop.append(told)
        try:
            node._push("estop", True)
            deadline = time.monotonic() + ESTOP_WAIT
            while not done.wait(0.05):
                lost = port_lost(node)
                if lost is not None:
                    return i.Trigger_Response(
                        False, f"{lost}; the estop is latched and control off is sent first when the port returns"
                    )
                if time.monotonic() >= deadline:
                    return i.Trigger_Response(False, f"no read-back of the stop within {ESTOP_WAIT:g} s")
        finally:
            node.on_stop.remove(told)
        return estop_answer(results[0], list(node.motors))


def estop_answer(result: StopResult, ids: list[int]) -> i.Trigger_Response:
    """Per motor: control off read back, or not confirmed; success only if every one reads off."""
    parts = []
    for device_id in sorted(set(ids) | set(result.stopped) | set(result.not_confirmed)):
        if device_id in result.stopped:
            parts.append(f"ID {device_id}: control off (read back)")
        else:
            said = result.control.get(str(device_id), "no answer")
            parts.append(f"ID {device_id}: NOT confirmed ({said}): stop it by other means (cut its power)")
    good = result.ok and all(i in result.stopped for i in ids)
    tail = "; latched: publish false on estop to accept commands again"
    return i.Trigger_Response(good, "estop: " + "; ".join(parts) + tail)


def _text(value: float | int | str) -> str:
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    return str(value)


def _unit(s: Any) -> str:
    unit = str(s.unit)
    return "" if not unit else unit if unit == ":1" else f" {unit}"
