"""The bridge's logic without I/O or clocks: ROS commands in, motor actions out; readings in, ROS messages out.

The node (node.py) feeds it what arrived and the time, carries out the actions it returns on
the bus, and publishes the messages it builds. Rules:

- Commands carry one value per joint, in `--ids` order; a message with the wrong count, a
  value that is not finite or out of the controller's range is refused whole (nothing moves).
- Positions are radians in the published (continuous, multi-turn) frame; they are turned into
  the device's frame with the offset seen in the latest reading, so a command means what
  joint_states shows. A velocity below the wire's 0.1 RPM is a stop: the motor holds.
- Command timeout: a joint turning under a velocity command holds (brakes to a stop and keeps
  its position) when no velocity command has come for `command_timeout` seconds (0 = never).
- E-stop true releases every motor (control off) and latches: commands are refused until
  estop false arrives. The next command after that turns control on again.
- Every JointState names every joint, in `--ids` order. A joint whose latest reading failed
  keeps its last good position, with velocity and effort NaN: the stale marker (a joint never
  read has NaN position too); /diagnostics says why and since when (docs/ros2.md, "Stale joints").
- Effort is amperes, or N·m for a joint given a torque constant (N·m/A).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..procedures.motor import POSITION_LIMIT, MotorState
from ..protocol.host import LIMITS
from . import msgs
from .convert import deg_to_rad, rad_s_to_rpm, rad_to_deg, rpm_to_rad_s

MIN_RPM = LIMITS["speed_rpm_min"]  # the wire's speed unit: below it a velocity command is a stop
MAX_RPM = LIMITS["speed_rpm_max"]
DEFAULT_COMMAND_TIMEOUT = 0.5  # s
DEFAULT_MOVE_VELOCITY = 2 * math.pi  # rad/s (60 RPM): speed of position moves
DEFAULT_RAMP = 0.1  # s to reach a commanded velocity (the wire's smallest ramp)
RESEND_SAME = 0.25  # s: an unchanged velocity is sent again this often (commands get no answer)


# -- what the node carries out on the bus ------------------------------------------------


@dataclass(frozen=True)
class MoveTo:
    id: int
    degrees: float  # in the device's frame
    rpm: float


@dataclass(frozen=True)
class Run:
    id: int
    rpm: float  # signed, |rpm| >= MIN_RPM
    ramp: float


@dataclass(frozen=True)
class Hold:
    id: int


@dataclass(frozen=True)
class ReleaseAll:
    ids: tuple[int, ...]


Action = MoveTo | Run | Hold | ReleaseAll


class Refused(ValueError):
    """A command the bridge will not carry out (the message says why)."""


@dataclass
class Joint:
    id: int
    name: str
    mode: str = "idle"  # idle | position | velocity | held | released
    rpm: float = 0.0  # last velocity sent
    sent_at: float = -math.inf  # when that velocity was last sent
    commanded_at: float = -math.inf  # when the last velocity command arrived
    state: MotorState | None = None
    sign: float = 1.0  # direction of travel between the last two readings
    reads: int = 0
    failures: int = 0
    missed: int = 0  # readings failed in a row (0 = the latest answered)
    error: str = ""

    def signed_rpm(self) -> float:
        """The joint's signed speed: the reading's (one rule, docs/library.md), or while it has no
        sign yet (the first reading of a turning motor) the direction between the last readings."""
        assert self.state is not None
        return self.state.speed if self.state.speed_signed else self.sign * abs(self.state.speed)


@dataclass
class Counters:
    commands: int = 0
    refused: int = 0
    timeouts: int = 0
    estops: int = 0
    last_refusal: str = ""


@dataclass
class Bridge:
    ids: Sequence[int]
    names: Sequence[str]
    command_timeout: float = DEFAULT_COMMAND_TIMEOUT
    move_velocity: float = DEFAULT_MOVE_VELOCITY
    ramp: float = DEFAULT_RAMP
    estop_latched: bool = False
    counters: Counters = field(default_factory=Counters)
    frame_id: str = ""  # header.frame_id of joint_states (e.g. "<prefix>base_link")
    torque_constants: Sequence[float] | None = None  # N·m/A per joint: effort in N·m instead of A
    joints: list[Joint] = field(init=False)
    fresh: list[Joint] = field(init=False, default_factory=list)  # read in the latest round

    def __post_init__(self) -> None:
        if len(self.ids) != len(self.names):
            raise ValueError(f"{len(self.names)} joint names for {len(self.ids)} motors")
        if not self.ids:
            raise ValueError("the bridge needs at least one motor")
        if self.command_timeout < 0 or not math.isfinite(self.command_timeout):
            raise ValueError(f"command timeout {self.command_timeout}: give seconds >= 0 (0 = off)")
        move_rpm = rad_s_to_rpm(self.move_velocity)
        if not MIN_RPM <= move_rpm <= MAX_RPM:
            raise ValueError(
                f"move velocity {self.move_velocity} rad/s: give "
                f"{rpm_to_rad_s(MIN_RPM):.4f}..{rpm_to_rad_s(MAX_RPM):.1f} rad/s"
            )
        if self.torque_constants is not None:
            if len(self.torque_constants) != len(self.ids):
                raise ValueError(f"{len(self.torque_constants)} torque constants for {len(self.ids)} motors")
            for value in self.torque_constants:
                if not (math.isfinite(value) and 0 < value <= 1000):
                    raise ValueError(f"torque constant {value}: give N·m/A > 0 (at most 1000), one per joint")
        self.joints = [Joint(i, n) for i, n in zip(self.ids, self.names, strict=True)]

    # -- commands ----------------------------------------------------------------------
    def _check(self, what: str, data: Sequence[float]) -> None:
        self.counters.commands += 1
        if self.estop_latched:
            raise Refused(f"{what}: estop is latched; publish false on estop to accept commands again")
        if len(data) != len(self.joints):
            raise Refused(f"{what}: {len(data)} values for {len(self.joints)} joints ({', '.join(self.names)})")
        for joint, value in zip(self.joints, data, strict=True):
            if not math.isfinite(value):
                raise Refused(f"{what}: {joint.name} = {value} is not a number")

    def _refuse(self, error: Refused) -> Refused:
        self.counters.refused += 1
        self.counters.last_refusal = str(error)
        return error

    def position_command(self, data: Sequence[float], now: float) -> list[Action]:
        """Radians per joint (published frame) -> a move to each; refused whole if any is wrong."""
        actions: list[Action] = []
        try:
            self._check("position_commands", data)
            for joint, radians in zip(self.joints, data, strict=True):
                if joint.state is None:
                    raise Refused(f"position_commands: no reading of {joint.name} yet (is ID {joint.id} answering?)")
                offset = joint.state.position - joint.state.device_position  # whole turns of the device counter
                degrees = rad_to_deg(radians) - offset
                if abs(degrees) > POSITION_LIMIT:
                    reach = deg_to_rad(POSITION_LIMIT)
                    raise Refused(
                        f"position_commands: {joint.name} = {radians:.4f} rad is out of the controller's reach "
                        f"({deg_to_rad(offset) - reach:.4f}..{deg_to_rad(offset) + reach:.4f} rad from here)"
                    )
                actions.append(MoveTo(joint.id, round(degrees, 2), rad_s_to_rpm(self.move_velocity)))
        except Refused as error:
            raise self._refuse(error) from None
        for joint in self.joints:
            joint.mode = "position"
        return actions

    def velocity_command(self, data: Sequence[float], now: float) -> list[Action]:
        """rad/s per joint -> run (or hold for a stop); refused whole if any is wrong."""
        try:
            self._check("velocity_commands", data)
            for joint, rad_s in zip(self.joints, data, strict=True):
                if abs(rad_s_to_rpm(rad_s)) > MAX_RPM:
                    raise Refused(
                        f"velocity_commands: {joint.name} = {rad_s} rad/s is beyond the controller's "
                        f"{rpm_to_rad_s(MAX_RPM):.1f} rad/s"
                    )
        except Refused as error:
            raise self._refuse(error) from None
        actions: list[Action] = []
        for joint, rad_s in zip(self.joints, data, strict=True):
            actions += velocity_actions(joint, rad_s, now, self.ramp)
        return actions

    def estop(self, engaged: bool, now: float) -> list[Action]:
        """True: release every motor and latch. False: accept commands again (motors stay released)."""
        if not engaged:
            self.estop_latched = False
            return []
        self.estop_latched = True
        self.counters.estops += 1
        for joint in self.joints:
            joint.mode = "released"
        return [ReleaseAll(tuple(self.ids))]

    def expire(self, now: float) -> list[Action]:
        """Hold each joint whose velocity commands stopped coming for longer than the timeout."""
        if self.command_timeout == 0:
            return []
        actions: list[Action] = []
        for joint in self.joints:
            if joint.mode == "velocity" and now - joint.commanded_at > self.command_timeout:
                actions.append(Hold(joint.id))
                joint.mode = "held"
                self.counters.timeouts += 1
        return actions

    def shutdown(self) -> list[Action]:
        """On the way out: hold the joints turning under velocity commands (nothing would stop them)."""
        actions: list[Action] = []
        for joint in self.joints:
            if joint.mode == "velocity":
                actions.append(Hold(joint.id))
                joint.mode = "held"
        return actions

    def next_expiry(self) -> float | None:
        """When expire() may next have something to do (None: nothing is timed)."""
        if self.command_timeout == 0:
            return None
        times = [j.commanded_at + self.command_timeout for j in self.joints if j.mode == "velocity"]
        return min(times) if times else None

    # -- readings -> messages ----------------------------------------------------------
    def readings(self, results: Mapping[int, MotorState | Exception]) -> None:
        """Take a round of readings: a state, or the error that came instead, per motor."""
        self.fresh = []
        for joint in self.joints:
            result = results.get(joint.id)
            if result is None or isinstance(result, Exception):
                result = result or RuntimeError(f"ID {joint.id} did not answer the group read")
                joint.failures += 1
                joint.missed += 1
                joint.error = str(result)
                continue
            if joint.state is not None and result.position != joint.state.position:
                joint.sign = 1.0 if result.position > joint.state.position else -1.0
            joint.state = result
            joint.reads += 1
            joint.missed = 0
            joint.error = ""
            self.fresh.append(joint)

    def joint_state(self, stamp_ns: int) -> msgs.JointState | None:
        """JointState of every joint in the fixed (--ids) order, or None if none answered this round.

        A joint that did not answer this round is stale: its last good position, velocity and
        effort NaN (position NaN too if it was never read); /diagnostics explains."""
        if not self.fresh:
            return None
        position, velocity, effort = [], [], []
        for index, joint in enumerate(self.joints):
            state = joint.state
            position.append(deg_to_rad(state.position) if state is not None else math.nan)
            if state is None or joint.missed:
                velocity.append(math.nan)
                effort.append(math.nan)
                continue
            velocity.append(rpm_to_rad_s(joint.signed_rpm()))
            kt = self.torque_constants[index] if self.torque_constants is not None else 1.0
            effort.append(state.current * kt)
        return msgs.JointState(
            header=msgs.Header(stamp=msgs.Time.from_ns(stamp_ns), frame_id=self.frame_id),
            name=list(self.names),
            position=position,
            velocity=velocity,
            effort=effort,
        )

    def diagnostics(self, stamp_ns: int, prefix: str, hardware: str, bus: Mapping[str, object]) -> msgs.DiagnosticArray:
        """One status per motor (reachable or not, its error) and one for the bus (statistics)."""
        statuses = []
        for joint in self.joints:
            if joint.error and joint.state is not None:
                level = msgs.DIAGNOSTIC_ERROR
                message = f"stale ({joint.missed} readings missed; joint_states keeps the last position, "
                message += f"velocity and effort NaN): {joint.error}"
            elif joint.error:
                level, message = msgs.DIAGNOSTIC_ERROR, f"never read (joint_states: NaN): {joint.error}"
            elif joint.state is None:
                level, message = msgs.DIAGNOSTIC_STALE, "not read yet"
            elif self.estop_latched:
                level, message = msgs.DIAGNOSTIC_WARN, "released by estop (latched)"
            elif joint.state.position_uncertain:  # nurimc.procedures.multiturn: whole turns may be missing
                level, message = msgs.DIAGNOSTIC_WARN, "position uncertain: readings too far apart for the speed"
            else:
                level, message = msgs.DIAGNOSTIC_OK, joint.mode
            values = {
                "id": joint.id,
                "reachable": joint.state is not None and not joint.error,
                "mode": joint.mode,
                "reads": joint.reads,
                "failed_reads": joint.failures,
                "missed_in_a_row": joint.missed,
                "stale": joint.missed > 0 or joint.state is None,
            }
            if joint.state is not None:
                values |= {
                    "position_rad": round(deg_to_rad(joint.state.position), 5),
                    "position_uncertain": joint.state.position_uncertain,
                    "current_a": joint.state.current,
                }
            statuses.append(
                msgs.DiagnosticStatus(
                    level=level,
                    name=f"{prefix}: {joint.name}",
                    message=message,
                    hardware_id=f"{hardware} id {joint.id}",
                    values=[msgs.KeyValue(k, _text(v)) for k, v in values.items()],
                )
            )
        c = self.counters
        bus_values = {
            **bus,
            "estop_latched": self.estop_latched,
            "commands": c.commands,
            "refused_commands": c.refused,
            "command_timeouts": c.timeouts,
            "last_refusal": c.last_refusal,
        }
        unreachable = sum(1 for j in self.joints if j.error)
        statuses.append(
            msgs.DiagnosticStatus(
                level=msgs.DIAGNOSTIC_WARN if unreachable else msgs.DIAGNOSTIC_OK,
                name=f"{prefix}: bus",
                message=f"{unreachable} of {len(self.joints)} motors not answering" if unreachable else "ok",
                hardware_id=hardware,
                values=[msgs.KeyValue(k, _text(v)) for k, v in bus_values.items()],
            )
        )
        return msgs.DiagnosticArray(header=msgs.Header(stamp=msgs.Time.from_ns(stamp_ns)), status=statuses)


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def velocity_actions(joint: Joint, rad_s: float, now: float, ramp: float) -> list[Action]:
    """What a velocity command for one joint sends (velocity_commands and the ros2_control topic
    alike): a speed under MIN_RPM holds the joint once; a speed runs it, resent when it changes or
    every RESEND_SAME seconds. Notes the command's time for the command timeout."""
    rpm = round(rad_s_to_rpm(rad_s), 1)
    joint.commanded_at = now
    if abs(rpm) < MIN_RPM:
        if joint.mode in ("held", "released", "idle"):
            return []
        joint.mode = "held"
        return [Hold(joint.id)]
    actions: list[Action] = []
    if joint.mode != "velocity" or rpm != joint.rpm or now - joint.sent_at >= RESEND_SAME:
        actions.append(Run(joint.id, rpm, ramp))
        joint.sent_at = now
    joint.mode, joint.rpm = "velocity", rpm
    return actions
