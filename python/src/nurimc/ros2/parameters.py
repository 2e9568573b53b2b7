"""The bridge node's ROS 2 parameters: what its six parameter services answer (docs/ros2.md,
"Parameters and services"). Transport-independent: request objects in, response objects out.

Two kinds of parameter:

- The bridge's own settings (`rate`, `command_timeout`, `move_velocity`, `ramp`, and read-only
  ones such as `ids` and `joint_names`), each with a descriptor (description, range, read_only).
  A set is checked whole first (type, range, read-only): a refused value changes nothing. A
  change is made on the node's thread (`BridgeNode.run_on_bus_thread`) and the value read back.
- Controller settings, `motor_<ID>.<setting>` (the names of `nurimc get --help`, with `_`): a
  get is a fresh read from the controller, a set a write then a read-back (the library's
  verified write), both as jobs of the bridge's bus service. A get that fails (no answer, the
  port lost) gives a value of type NOT_SET (get_parameters has no field for an error; the reason
  is in the bridge's log, and read_setting gives it in its answer).

Every handler answers, whatever happens: errors become the response's fields, never an exception.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..cli.common import Number
from ..cli.motion import RAMP
from ..cli.ros2_limits import (
    COMMAND_TIMEOUT,
    MAX_ANGULAR,
    MAX_ANGULAR_ACCEL,
    MAX_LINEAR,
    MAX_LINEAR_ACCEL,
    MOVE_VELOCITY,
    RATE,
)
from ..errors import NurimcError, PortLost
from ..procedures.settings import SETTINGS, Setting
from ..service.core import COMMAND, READ, Cancelled
from . import interfaces as i

if TYPE_CHECKING:
    from .node import BridgeNode

SEPARATOR = "."
APPLY_TIMEOUT = 2.0  # s a change may wait for the node's thread
JOB_TIMEOUT = 5.0  # s a bus job of a service may take (queue and bus), then the answer says so
MOTOR_PREFIX = "motor_"
RESTART = "it is fixed at start: restart the bridge with {option}"

Value = bool | int | float | str | list[str] | list[int] | list[float] | None


class Refusal(Exception):
    """A parameter or service request refused; the text is the reason given in the answer."""


# -- values ------------------------------------------------------------------------------------


def to_value(value: Value, kind: int | None = None) -> i.ParameterValue:
    """A Python value as a ParameterValue (of `kind`, else of the value's own type)."""
    if value is None:
        return i.ParameterValue(type=i.PARAMETER_NOT_SET)
    if kind is None:
        kind = _kind_of(value)
    if kind == i.PARAMETER_BOOL:
        return i.ParameterValue(type=kind, bool_value=bool(value))
    if kind == i.PARAMETER_INTEGER:
        assert isinstance(value, int | float)
        return i.ParameterValue(type=kind, integer_value=int(value))
    if kind == i.PARAMETER_DOUBLE:
        assert isinstance(value, int | float)
        return i.ParameterValue(type=kind, double_value=float(value))
    if kind == i.PARAMETER_STRING:
        return i.ParameterValue(type=kind, string_value=str(value))
    assert isinstance(value, list)
    if kind == i.PARAMETER_STRING_ARRAY:
        return i.ParameterValue(type=kind, string_array_value=[str(v) for v in value])
    if kind == i.PARAMETER_INTEGER_ARRAY:
        return i.ParameterValue(type=kind, integer_array_value=[int(v) for v in value])
    return i.ParameterValue(type=i.PARAMETER_DOUBLE_ARRAY, double_array_value=[float(v) for v in value])


def _kind_of(value: Value) -> int:
    if isinstance(value, bool):
        return i.PARAMETER_BOOL
    if isinstance(value, int):
        return i.PARAMETER_INTEGER
    if isinstance(value, float):
        return i.PARAMETER_DOUBLE
    if isinstance(value, str):
        return i.PARAMETER_STRING
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return i.PARAMETER_STRING_ARRAY
    if isinstance(value, list) and all(isinstance(v, int) and not isinstance(v, bool) for v in value):
        return i.PARAMETER_INTEGER_ARRAY
    return i.PARAMETER_DOUBLE_ARRAY


def from_value(value: i.ParameterValue) -> Value:
    """The Python value a ParameterValue holds (None: NOT_SET)."""
    kind = value.type
    if kind == i.PARAMETER_BOOL:
        return bool(value.bool_value)
    if kind == i.PARAMETER_INTEGER:
        return int(value.integer_value)
    if kind == i.PARAMETER_DOUBLE:
        return float(value.double_value)
    if kind == i.PARAMETER_STRING:
        return str(value.string_value)
    if kind == i.PARAMETER_STRING_ARRAY:
        return [str(v) for v in value.string_array_value]
    if kind == i.PARAMETER_INTEGER_ARRAY:
        return [int(v) for v in value.integer_array_value]
    if kind == i.PARAMETER_DOUBLE_ARRAY:
        return [float(v) for v in value.double_array_value]
    return None  # NOT_SET, and the array types no parameter of ours has (byte, bool)


def _type_name(kind: int) -> str:
    return i.TYPE_NAMES.get(kind, f"type {kind}")


def _number(name: str, value: i.ParameterValue, kind: int) -> float:
    """A number parameter's value: a double, or an integer where a double is asked (widened)."""
    if value.type == kind == i.PARAMETER_INTEGER:
        return int(value.integer_value)
    if kind == i.PARAMETER_DOUBLE and value.type in (i.PARAMETER_DOUBLE, i.PARAMETER_INTEGER):
        number = float(value.double_value if value.type == i.PARAMETER_DOUBLE else value.integer_value)
        if not math.isfinite(number):
            raise Refusal(f"{name}: {number} is not a number")
        return number
    wanted = _type_name(kind)
    raise Refusal(f"{name}: wrong type {_type_name(value.type)}; give {'an' if wanted[0] in 'aeiou' else 'a'} {wanted}")


# -- the bridge's own parameters ------------------------------------------------------------


@dataclass(frozen=True)
class BridgeParameter:
    name: str
    kind: int
    description: str
    read: Callable[[], Value]
    #: checks a value (Refusal with the reason) and returns what apply() takes; None: read-only
    check: Callable[[i.ParameterValue], Any] | None = None
    apply: Callable[[Any], None] | None = None  # on the node's thread
    low: float | None = None
    high: float | None = None
    step: float = 0.0
    fixed: str = ""  # read-only: how to change it (the option to restart with)

    def descriptor(self) -> i.ParameterDescriptor:
        d = i.ParameterDescriptor(name=self.name, type=self.kind, description=self.description)
        d.read_only = self.check is None
        if d.read_only:
            d.additional_constraints = f"read-only while the bridge runs; {RESTART.format(option=self.fixed)}"
        if self.low is not None and self.high is not None:
            if self.kind == i.PARAMETER_INTEGER:
                d.integer_range = [i.IntegerRange(int(self.low), int(self.high), int(self.step))]
            else:
                d.floating_point_range = [i.FloatingPointRange(self.low, self.high, self.step)]
        return d


def _in_range(name: str, number: float, low: float, high: float, unit: str) -> float:
    if not low <= number <= high:
        raise Refusal(f"{name}: {number:g} is out of range {low:g}..{high:g} {unit}".rstrip())
    return number


def bridge_parameters(node: BridgeNode) -> list[BridgeParameter]:
    bridge = node.bridge

    def number(name: str, low: float, high: float, unit: str) -> Callable[[i.ParameterValue], float]:
        return lambda value: _in_range(name, _number(name, value, i.PARAMETER_DOUBLE), low, high, unit)

    def set_bridge(attribute: str) -> Callable[[Any], None]:
        return lambda value: setattr(bridge, attribute, float(value))

    fixed = [
        BridgeParameter(
            "ids", i.PARAMETER_INTEGER_ARRAY, "controller IDs, in joint order", lambda: list(bridge.ids), fixed="--ids"
        ),
        BridgeParameter(
            "joint_names",
            i.PARAMETER_STRING_ARRAY,
            "joint names, one per ID (joint_states' name)",
            lambda: list(bridge.names),
            fixed="--joint-names",
        ),
        BridgeParameter(
            "frame_id",
            i.PARAMETER_STRING,
            "header.frame_id of joint_states",
            lambda: bridge.frame_id,
            fixed="--frame-prefix/--base-frame",
        ),
        BridgeParameter(
            "torque_constants",
            i.PARAMETER_DOUBLE_ARRAY,
            "N·m/A per joint: effort in N·m (empty: effort in amperes)",
            lambda: [float(k) for k in bridge.torque_constants or []],
            fixed="--torque-constants",
        ),
        BridgeParameter(
            "namespace",
            i.PARAMETER_STRING,
            "namespace of the bridge's topics",
            lambda: node.namespace,
            fixed="--namespace",
        ),
        BridgeParameter(
            "broadcast_read",
            i.PARAMETER_BOOL,
            "all motors read with one broadcast request",
            lambda: node.broadcast_read,
            fixed="--broadcast-read",
        ),
        BridgeParameter("port", i.PARAMETER_STRING, "the RS485 port", lambda: node.bus.transport.url, fixed="--port"),
        BridgeParameter(
            "baud", i.PARAMETER_INTEGER, "the bus's rate, bps", lambda: int(node.bus.baudrate), fixed="--baud"
        ),
    ]
    writable = [
        BridgeParameter(
            "rate",
            i.PARAMETER_DOUBLE,
            "joint_states per second (readings/s); 0 = as fast as the bus allows. A change subscribes the "
            "bus service's poll again at the new rate",
            lambda: float(node.rate),
            number("rate", RATE.low, RATE.high, "readings/s"),
            lambda value: node.set_rate(float(value)),
            RATE.low,
            RATE.high,
        ),
        BridgeParameter(
            "command_timeout",
            i.PARAMETER_DOUBLE,
            "s without velocity_commands before a turning motor holds; 0 = off",
            lambda: float(bridge.command_timeout),
            number("command_timeout", COMMAND_TIMEOUT.low, COMMAND_TIMEOUT.high, "s"),
            set_bridge("command_timeout"),
            COMMAND_TIMEOUT.low,
            COMMAND_TIMEOUT.high,
        ),
        BridgeParameter(
            "move_velocity",
            i.PARAMETER_DOUBLE,
            "rad/s of moves to position_commands (the controller's 0.1..6553.3 RPM)",
            lambda: float(bridge.move_velocity),
            number("move_velocity", MOVE_VELOCITY.low, MOVE_VELOCITY.high, "rad/s"),
            set_bridge("move_velocity"),
            MOVE_VELOCITY.low,
            MOVE_VELOCITY.high,
        ),
        BridgeParameter(
            "ramp",
            i.PARAMETER_DOUBLE,
            "s to reach a commanded velocity (the wire's 0.1 s steps)",
            lambda: float(bridge.ramp),
            lambda value: round(number("ramp", RAMP.low, RAMP.high, "s")(value), 1),  # the wire's 0.1 s
            set_bridge("ramp"),
            RAMP.low,
            RAMP.high,
            0.1,
        ),
    ]
    return writable + fixed + base_parameters(node)


BASE_PREFIX = "base" + SEPARATOR
#: the mobile base's limits a parameter may change: (config field, its option's range, what it is)
BASE_LIMITS: list[tuple[str, Number, str]] = [
    ("max_linear", MAX_LINEAR, "speed limit of the base, m/s"),
    ("max_angular", MAX_ANGULAR, "turn-rate limit of the base, rad/s"),
    ("max_linear_accel", MAX_LINEAR_ACCEL, "acceleration limit of the base, m/s²"),
    ("max_angular_accel", MAX_ANGULAR_ACCEL, "angular acceleration limit of the base, rad/s²"),
    ("timeout", COMMAND_TIMEOUT, "s without cmd_vel before the base decelerates to a stop; 0 = off"),
]


def base_parameters(node: BridgeNode) -> list[BridgeParameter]:
    """With --diff-drive: the base's limits (writable; checked together, as at start) and its geometry."""
    base = node.base
    if base is None:
        return []

    def number(name: str, option: Number) -> Callable[[i.ParameterValue], float]:
        return lambda value: _in_range(name, _number(name, value, i.PARAMETER_DOUBLE), option.low, option.high, "")

    def setter(field: str) -> Callable[[Any], None]:
        return lambda value: setattr(base, "config", dataclasses.replace(base.config, **{field: float(value)}))

    def reader(field: str) -> Callable[[], Value]:
        return lambda: getattr(base.config, field)

    out = []
    for field, option, text in BASE_LIMITS:
        name = BASE_PREFIX + field
        check, apply = number(name, option), setter(field)
        out.append(BridgeParameter(name, i.PARAMETER_DOUBLE, text, reader(field), check, apply, *_range(option)))
    for field, kind, text, flag in [
        ("wheel_radius", i.PARAMETER_DOUBLE, "wheel radius, m", "--wheel-radius"),
        ("wheel_separation", i.PARAMETER_DOUBLE, "distance between the wheels, m", "--wheel-separation"),
        ("left_id", i.PARAMETER_INTEGER, "ID of the left wheel's motor", "--diff-drive"),
        ("right_id", i.PARAMETER_INTEGER, "ID of the right wheel's motor", "--diff-drive"),
        ("odom_frame", i.PARAMETER_STRING, "frame id of the odometry", "--odom-frame"),
        ("base_frame", i.PARAMETER_STRING, "frame id of the base", "--base-frame"),
    ]:
        out.append(BridgeParameter(BASE_PREFIX + field, kind, text, reader(field), fixed=flag))
    return out


def _range(option: Number) -> tuple[float, float]:
    return option.low, option.high


def check_base(node: BridgeNode, changes: list[tuple[BridgeParameter, Any]]) -> None:
    """The base's limits as they would be after `changes`, checked together as at start (the
    wheels must be able to carry max_linear and max_angular at once): Refusal if not."""
    base = node.base
    fields = {p.name[len(BASE_PREFIX) :]: float(v) for p, v in changes if p.name.startswith(BASE_PREFIX)}
    if base is None or not fields:
        return
    try:
        dataclasses.replace(base.config, **fields).check()
    except ValueError as error:
        names = ", ".join(BASE_PREFIX + f for f in fields)
        raise Refusal(f"{names}: {error}") from None


# -- controller settings as parameters ------------------------------------------------------


def setting_kind(s: Setting) -> int:
    """A setting's parameter type: a choice is a string (cw, on...), a quantized value a double,
    the rest integers."""
    return {"choice": i.PARAMETER_STRING, "quantize": i.PARAMETER_DOUBLE}.get(s.input, i.PARAMETER_INTEGER)


def setting_parameter_name(device_id: int, s: Setting) -> str:
    return f"{MOTOR_PREFIX}{device_id}{SEPARATOR}{s.name.replace('-', '_')}"


def setting_descriptor(device_id: int, s: Setting) -> i.ParameterDescriptor:
    kind = setting_kind(s)
    unit = f" ({s.unit})" if s.unit and s.unit != ":1" else (" (:1)" if s.unit else "")
    d = i.ParameterDescriptor(
        name=setting_parameter_name(device_id, s),
        type=kind,
        description=f"ID {device_id}: {s.doc}{unit}; get reads the controller, set writes then reads back",
        read_only=s.command is None,
    )
    spec = s.spec
    if spec.values:
        d.additional_constraints = "one of: " + ", ".join(name for _, name in spec.values)
    else:
        low, high = s.to_physical(spec.min), s.to_physical(spec.max)
        assert isinstance(low, int | float) and isinstance(high, int | float)
        if kind == i.PARAMETER_INTEGER:
            d.integer_range = [i.IntegerRange(int(low), int(high), 1)]
        else:
            d.floating_point_range = [i.FloatingPointRange(float(low), float(high), float(spec.scale))]
        d.additional_constraints = f"{s.describe_range()} (the protocol's range; some products allow less)"
    if s.command is None:
        d.additional_constraints += "; read-only (the controller's own)"
    return d


def setting_of(name: str, ids: Sequence[int]) -> tuple[int, Setting] | None:
    """`motor_<ID>.<setting>` -> (ID, setting), None if it names no setting of a bridge motor."""
    head, dot, tail = name.partition(SEPARATOR)
    if not dot or not head.startswith(MOTOR_PREFIX) or not head[len(MOTOR_PREFIX) :].isdigit():
        return None
    device_id = int(head[len(MOTOR_PREFIX) :])
    s = SETTINGS.get(tail.replace("_", "-"))
    if device_id not in ids or s is None:
        return None
    return device_id, s


def setting_wire_value(s: Setting, value: i.ParameterValue, name: str) -> object:
    """What a set_parameters value of a setting gives Setting.to_wire (type checked here)."""
    kind = setting_kind(s)
    if kind == i.PARAMETER_STRING:
        if value.type != i.PARAMETER_STRING:
            raise Refusal(f"{name}: wrong type {_type_name(value.type)}; give a string: {s.describe_range()}")
        return value.string_value
    number = _number(name, value, kind)
    try:
        s.to_wire(number)
    except ValueError:
        raise Refusal(f"{name}: {number:g} is out of range {s.describe_range()}") from None
    return number


# -- the parameter services ---------------------------------------------------------------------


class BridgeParameters:
    """The six parameter services of the bridge node (rclpy's semantics)."""

    def __init__(self, node: BridgeNode, node_path: str = "/nurimc") -> None:
        self.node = node
        self.node_path = node_path  # "/arm/nurimc": said in refusals (ros2 param list /arm/nurimc)
        self._own: dict[str, BridgeParameter] = {}
        self._for_base: Any = False

    @property
    def own(self) -> dict[str, BridgeParameter]:
        """The bridge's own parameters (with the base's once diffdrive.attach gave the node one)."""
        if self._for_base is not self.node.base:
            self._own = {p.name: p for p in bridge_parameters(self.node)}
            self._for_base = self.node.base
        return self._own

    # -- names -------------------------------------------------------------------------
    def setting_names(self) -> list[str]:
        names = []
        for device_id, motor in self.node.motors.items():
            line = motor.procedures.line
            names += [setting_parameter_name(device_id, s) for s in SETTINGS.values() if line.has(s.request)]
        return names

    def names(self) -> list[str]:
        return [*self.own, *self.setting_names()]

    def _setting(self, name: str) -> tuple[int, Setting] | None:
        found = setting_of(name, list(self.node.motors))
        if found is None or not self.node.motors[found[0]].procedures.line.has(found[1].request):
            return None
        return found

    # -- list ----------------------------------------------------------------------------
    def list_parameters(self, request: i.ListParameters_Request) -> i.ListParameters_Response:
        """Every name under one of `prefixes` (all without), at most `depth` levels below it (0: all)."""
        result = i.ListParametersResult()
        depth = int(request.depth)
        for name in self.names():
            if request.prefixes:
                bases = [p for p in request.prefixes if name.startswith(p + SEPARATOR)]
                if not bases:
                    continue
                below = name[len(bases[0]) + 1 :]
            else:
                below = name
            if depth and below.count(SEPARATOR) >= depth:
                continue
            result.names.append(name)
            if SEPARATOR in name:
                prefix = name.rsplit(SEPARATOR, 1)[0]
                if prefix not in result.prefixes:
                    result.prefixes.append(prefix)
        return i.ListParameters_Response(result=result)

    # -- get -----------------------------------------------------------------------------
    def get_parameters(self, request: i.GetParameters_Request) -> i.GetParameters_Response:
        """In the order asked; an unknown name or a setting that could not be read: NOT_SET."""
        values: list[i.ParameterValue | None] = [None] * len(request.names)
        wanted: dict[int, list[tuple[int, Setting]]] = {}
        for index, name in enumerate(request.names):
            own = self.own.get(name)
            if own is not None:
                values[index] = to_value(own.read(), own.kind)
                continue
            found = self._setting(name)
            if found is None:
                self.node._report("get-unknown", f"get_parameters: no parameter {name!r} (ros2 param list shows them)")
                continue
            wanted.setdefault(found[0], []).append((index, found[1]))
        for device_id, settings in wanted.items():
            try:
                read = self.read_settings(device_id, [s for _, s in settings])
            except Refusal as error:
                self.node._report(f"get{device_id}", f"get_parameters: ID {device_id}: {error} (value not set)")
                continue
            for index, s in settings:
                values[index] = to_value(read[s.name], setting_kind(s))
        return i.GetParameters_Response(values=[v or i.ParameterValue() for v in values])

    def read_settings(self, device_id: int, settings: Sequence[Setting]) -> dict[str, float | int | str]:
        """Fresh reads of some settings of one motor (each answer message once), as one job."""
        procedures = self.node.motors[device_id].procedures

        def work() -> Any:
            answers: dict[str, Any] = {}
            out: dict[str, float | int | str] = {}
            for s in settings:
                if s.answer not in answers:
                    answers[s.answer] = yield from procedures.core.ask(procedures._request(s.request, s.name))
                out[s.name] = procedures.setting_from(s, answers[s.answer])
            return out

        result: dict[str, float | int | str] = bus_job(self.node, work(), READ)
        return result

    # -- types and descriptions ----------------------------------------------------------
    def get_parameter_types(self, request: i.GetParameterTypes_Request) -> i.GetParameterTypes_Response:
        types = []
        for name in request.names:
            own = self.own.get(name)
            found = None if own is not None else self._setting(name)
            types.append(own.kind if own else setting_kind(found[1]) if found else i.PARAMETER_NOT_SET)
        return i.GetParameterTypes_Response(types=types)

    def describe_parameters(self, request: i.DescribeParameters_Request) -> i.DescribeParameters_Response:
        descriptors = []
        for name in request.names:
            own = self.own.get(name)
            found = None if own is not None else self._setting(name)
            if own is not None:
                descriptors.append(own.descriptor())
            elif found is not None:
                descriptors.append(setting_descriptor(*found))
            else:
                descriptors.append(i.ParameterDescriptor(name=name, description="no such parameter"))
        return i.DescribeParameters_Response(descriptors=descriptors)

    # -- set -----------------------------------------------------------------------------
    def set_parameters(self, request: i.SetParameters_Request) -> i.SetParameters_Response:
        """One result per parameter, in order, each set (or refused) on its own, as rclpy does."""
        results = []
        for parameter in request.parameters:
            results.append(self._set([parameter]))
        return i.SetParameters_Response(results=results)

    def set_parameters_atomically(
        self, request: i.SetParametersAtomically_Request
    ) -> i.SetParametersAtomically_Response:
        """All or none: every value checked first; at most one controller setting (its write is the
        one step that can fail once begun, so it goes first and nothing else is changed if it does)."""
        return i.SetParametersAtomically_Response(result=self._set(list(request.parameters)))

    def _set(self, parameters: list[i.Parameter]) -> i.SetParametersResult:
        try:
            changes, writes = self._check(parameters)
            if len(writes) > 1:
                names = ", ".join(p.name for p, _, _ in writes)
                raise Refusal(
                    f"{names}: controller settings are written one at a time (each is a write to the "
                    "controller's memory, verified by reading back); set them with set_parameters, not atomically"
                )
            done = []
            for parameter, (device_id, s), value in writes:
                done.append(f"{parameter.name} = {self.write_setting(device_id, s, value)} (read back)")
            if changes:
                done += self._apply(changes)
        except Refusal as error:
            return i.SetParametersResult(successful=False, reason=str(error))
        return i.SetParametersResult(successful=True, reason="; ".join(done))

    def _check(
        self, parameters: list[i.Parameter]
    ) -> tuple[list[tuple[BridgeParameter, Any]], list[tuple[i.Parameter, tuple[int, Setting], object]]]:
        """Every value checked before anything changes (Refusal names the first wrong one)."""
        changes: list[tuple[BridgeParameter, Any]] = []
        writes: list[tuple[i.Parameter, tuple[int, Setting], object]] = []
        seen: set[str] = set()
        for parameter in parameters:
            name = parameter.name
            if name in seen:
                raise Refusal(f"{name}: given twice")
            seen.add(name)
            if parameter.value.type == i.PARAMETER_NOT_SET:
                raise Refusal(f"{name}: the bridge's parameters cannot be undeclared (value not set)")
            own = self.own.get(name)
            if own is not None:
                if own.check is None:
                    raise Refusal(f"{name} is read-only: {RESTART.format(option=own.fixed)}")
                changes.append((own, own.check(parameter.value)))
                continue
            found = self._setting(name)
            if found is None:
                raise Refusal(f"{name}: no such parameter (ros2 param list {self.node_path} shows them)")
            s = found[1]
            if s.command is None:
                raise Refusal(f"{name} is read-only: the controller's own ({s.doc})")
            writes.append((parameter, found, setting_wire_value(s, parameter.value, name)))
        check_base(self.node, changes)
        return changes, writes

    def _apply(self, changes: list[tuple[BridgeParameter, Any]]) -> list[str]:
        """All the checked values at once on the node's thread, then each read back."""

        def change() -> list[str]:
            for parameter, value in changes:
                assert parameter.apply is not None
                parameter.apply(value)
            return [f"{p.name} = {p.read()}" for p, _ in changes]

        try:
            return self.node.run_on_bus_thread(change, APPLY_TIMEOUT)
        except concurrent.futures.TimeoutError:
            raise Refusal(
                f"not applied within {APPLY_TIMEOUT:g} s (an estop came first, or the bridge is busy); set it again"
            ) from None
        except ValueError as error:
            raise Refusal(str(error)) from None

    def write_setting(self, device_id: int, s: Setting, value: object) -> float | int | str:
        """Write a setting, read it back (a fresh read after the library's verified write); the
        value read back, or Refusal saying why not."""
        if s.name == "control" and str(value).lower() == "on" and self.node.bridge.estop_latched:
            raise Refusal("control on refused: the estop is latched; publish false on estop first")
        procedures = self.node.motors[device_id].procedures

        def work() -> Any:
            written = yield from procedures.set(s.name, value)
            read = yield from procedures.get(s.name)
            return written, read

        written, read = bus_job(self.node, work(), COMMAND)
        if read != written:
            raise Refusal(f"ID {device_id}: wrote {s.name} = {written} but it reads {read}")
        value_read: float | int | str = read
        return value_read


# -- bus jobs ---------------------------------------------------------------------------------------


def port_lost(node: BridgeNode) -> str | None:
    """The outage, said as the answer to a service call made while the port is lost (None: it is up)."""
    for guard in (node.outage, node.service.outage):
        if guard.down and guard.transport is not None:
            return guard.transport.lost_text()
    return None


def bus_job(node: BridgeNode, work: Any, priority: int) -> Any:
    """A job of the bridge's bus service, waited for at most JOB_TIMEOUT (its result, or Refusal
    with the reason: the port lost, no answer, a value refused, an emergency stop first)."""
    lost = port_lost(node)
    if lost is not None:
        raise Refusal(lost)
    service = node.service
    try:
        if service._thread is None:  # stepped by its caller (tests on virtual time): run it here
            return service.run(work, priority, timeout=JOB_TIMEOUT)
        future = service.submit(work, priority, timeout=JOB_TIMEOUT)
        try:
            return future.result(JOB_TIMEOUT + APPLY_TIMEOUT)
        except concurrent.futures.TimeoutError:
            future.cancel()
            raise Refusal(f"the bus did not carry the request out within {JOB_TIMEOUT:g} s; try again") from None
    except PortLost as error:
        raise Refusal(port_lost(node) or str(error)) from None
    except Cancelled:
        raise Refusal("cancelled: an emergency stop came first") from None
    except (NurimcError, ValueError) as error:
        raise Refusal(str(error)) from None
