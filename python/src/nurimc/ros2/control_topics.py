"""ros2_control without C++: the contract of ros2_control's topic-based hardware interface.

`topic_based_ros2_control/TopicBasedSystem` (PickNik) and its successor in ros-controls,
`joint_state_topic_hardware_interface/JointStateTopicSystem`, let a controller manager drive
hardware through two `sensor_msgs/JointState` topics. Their code (not their README, which names
`/robot_joint_command`) defaults to:

- `joint_commands_topic` = `/robot_joint_commands`: the interface publishes (reliable, keep last 1)
  one JointState per cycle naming every joint of its `<ros2_control>` block, in URDF order; for each
  joint it appends the joint's commanded `position`, `velocity` and `effort`, each only if that joint
  has that command interface (so a field is either empty or one value per named joint when all
  joints declare the same interfaces).
- `joint_states_topic` = `/robot_joint_states`: it reads joint states from there (best effort;
  our reliable writer matches), by joint name.

Here: a command names joints (by `--joint-names`); position (rad, the published frame) moves the
joint, at |velocity| when a velocity comes with it, else at `--move-velocity`; velocity alone turns
it (rad/s, the command timeout applies as to velocity_commands); an empty field means "not
commanded". Names that are not this bridge's joints are skipped: the topic is shared, so one
controller manager can drive the joints of several bridges (several buses) through it; a message
naming none of ours is not for us. A message with a field whose length is neither 0 nor the
number of names, with effort values for our joints (these controllers take no torque command) or
non-finite values is refused whole, and counted in /diagnostics.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from ..procedures.motor import POSITION_LIMIT
from . import msgs
from .bridge import MAX_RPM, MIN_RPM, RESEND_SAME, Action, Bridge, MoveTo, Refused, velocity_actions
from .convert import rad_s_to_rpm, rad_to_deg

DEFAULT_COMMANDS_TOPIC = "/robot_joint_commands"
DEFAULT_STATES_TOPIC = "/robot_joint_states"
WHAT = "joint commands"


def _field(name: str, values: Sequence[float], count: int) -> list[float] | None:
    if not values:
        return None
    if len(values) != count:
        raise Refused(
            f"{WHAT}: {len(values)} {name} values for {count} joint names (give one per name, or none; "
            "declare the same command interfaces for every joint of the <ros2_control> block)"
        )
    for value in values:
        if not math.isfinite(value):
            raise Refused(f"{WHAT}: {name} {value} is not a number")
    return list(values)


class JointCommands:
    """JointState commands -> motor actions, on the bridge's joints (no I/O: the node carries them out)."""

    def __init__(self, bridge: Bridge) -> None:
        self.bridge = bridge
        self._last_move: dict[int, tuple[float, float, float]] = {}  # id -> (degrees, rpm, when)

    def command(
        self,
        names: Sequence[str],
        position: Sequence[float],
        velocity: Sequence[float],
        effort: Sequence[float],
        now: float,
    ) -> list[Action]:
        bridge = self.bridge
        joints = {j.name: j for j in bridge.joints}
        ours = [i for i, name in enumerate(names) if name in joints]
        if not ours:
            return []  # another bridge's joints
        try:
            bridge.counters.commands += 1
            if bridge.estop_latched:
                raise Refused(f"{WHAT}: estop is latched; publish false on estop to accept commands again")
            if len(set(names)) != len(names):
                raise Refused(f"{WHAT}: a joint is named twice")
            if effort and len(effort) == len(names) and any(effort[i] for i in ours):
                raise Refused(f"{WHAT}: effort commands are not supported (use position or velocity interfaces)")
            positions = _field("position", position, len(names))
            velocities = _field("velocity", velocity, len(names))
            if effort and len(effort) != len(names):
                _field("effort", effort, len(names))
            plan: list[tuple[Any, float | None, float | None]] = []
            for i in ours:
                name = names[i]
                joint = joints[name]
                radians = positions[i] if positions is not None else None
                rad_s = velocities[i] if velocities is not None else None
                if rad_s is not None and abs(rad_s_to_rpm(rad_s)) > MAX_RPM:
                    raise Refused(f"{WHAT}: {name} velocity {rad_s} rad/s is beyond the controller's reach")
                if radians is not None:
                    if joint.state is None:
                        raise Refused(f"{WHAT}: no reading of {name} yet (is ID {joint.id} answering?)")
                    offset = joint.state.position - joint.state.device_position
                    if abs(rad_to_deg(radians) - offset) > POSITION_LIMIT:
                        raise Refused(f"{WHAT}: {name} = {radians:.4f} rad is out of the controller's reach")
                plan.append((joint, radians, rad_s))
        except Refused as error:
            bridge.counters.refused += 1
            bridge.counters.last_refusal = str(error)
            raise
        actions: list[Action] = []
        for joint, radians, rad_s in plan:
            if radians is not None:
                assert joint.state is not None
                degrees = round(rad_to_deg(radians) - (joint.state.position - joint.state.device_position), 2)
                # the trajectory's velocity with its position; none (or zero, at a trajectory's end): the move speed
                speed = abs(rad_s_to_rpm(rad_s)) if rad_s is not None else 0.0
                rpm = round(speed if speed >= MIN_RPM else rad_s_to_rpm(bridge.move_velocity), 1)
                last = self._last_move.get(joint.id)
                if (
                    joint.mode != "position"
                    or last is None
                    or last[:2] != (degrees, rpm)
                    or now - last[2] >= RESEND_SAME
                ):
                    actions.append(MoveTo(joint.id, degrees, rpm))
                    self._last_move[joint.id] = (degrees, rpm, now)
                joint.mode = "position"
            elif rad_s is not None:
                actions += velocity_actions(joint, rad_s, now, bridge.ramp)
        return actions


def attach(node: Any, commands_topic: str, states_topic: str) -> JointCommands:
    """Subscribe the command topic and publish every joint_states message on the states topic too."""
    logic = JointCommands(node.bridge)
    writer = node.participant.writer(states_topic, msgs.JointState)

    def on_data(reader: Any) -> None:
        for sample in reader.take(N=64):
            if isinstance(sample, msgs.JointState):
                # latest wins per set of joints (coalesce.py): a 1 kHz controller costs no backlog
                node.call_on_bus_thread(_command(logic, sample), key="control:" + ",".join(sorted(sample.name)))

    node.participant.reader(commands_topic, msgs.JointState, on_data)
    previous = node.sink

    class _Mirror:
        def joint_state(self, topic: str, message: msgs.JointState) -> None:
            writer.write(message)
            if previous is not None:
                previous.joint_state(topic, message)

    node.sink = _Mirror()
    return logic


def _command(logic: JointCommands, sample: msgs.JointState) -> Callable[[float], list[Action]]:
    names, position, velocity, effort = (
        list(sample.name),
        list(sample.position),
        list(sample.velocity),
        list(sample.effort),
    )
    return lambda now: logic.command(names, position, velocity, effort, now)
