"""Mobile base mode: two wheel motors as a differential-drive base (cmd_vel in, odom and /tf out).

Sans-I/O like bridge.py: `DiffDrive` takes velocity commands and the time, returns wheel actions;
takes the wheel readings, returns the odometry. The node carries the actions out on the bus thread
(after each reading, `tick`) and publishes what `odometry` builds.

- Commands: linear.x (m/s) and angular.z (rad/s) of `geometry_msgs/Twist` (or `TwistStamped`),
  clamped to the speed limits; the wheels follow them within the acceleration limits.
- Command timeout: when no command has come for `timeout` s the target becomes zero, and the base
  decelerates within the same limits (a released wheel on a slope rolls: we never release). Once
  both wheels are at zero speed they hold their position.
  TODO(#24): when `Motor.stop()` exists (speed 0, confirmed, then hold), the final Hold becomes it.
- Odometry: the pose is integrated from the wheels' positions (continuous, multi-turn), the twist
  comes from the wheels' speeds; covariances: see POSE_COVARIANCE / TWIST_COVARIANCE.
- Wheel sign: a wheel's forward travel is +radius x its motor's angle (rad), or - with `inverted`
  (mirror-mounted motors: usually one side is inverted).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from .base_msgs import (
    Odometry,
    Point,
    Pose,
    PoseWithCovariance,
    Quaternion,
    TFMessage,
    Transform,
    TransformStamped,
    Twist,
    TwistStamped,
    TwistWithCovariance,
    Vector3,
)
from .bridge import MAX_RPM, MIN_RPM, RESEND_SAME, Action, Bridge, Hold, Joint, Refused, Run
from .convert import deg_to_rad, rad_s_to_rpm, rpm_to_rad_s
from .msgs import DIAGNOSTIC_OK, DIAGNOSTIC_WARN, DiagnosticArray, DiagnosticStatus, Header, KeyValue, Time
from .names import topic

NOT_MEASURED = 1e6  # variance of what a planar base does not measure (z, roll, pitch)
#: diagonal (x, y, z, roll, pitch, yaw) of the pose covariance: m^2 and rad^2
POSE_COVARIANCE = (1e-3, 1e-3, NOT_MEASURED, NOT_MEASURED, NOT_MEASURED, 1e-2)
#: diagonal (vx, vy, vz, wx, wy, wz) of the twist covariance: (m/s)^2 and (rad/s)^2
TWIST_COVARIANCE = (1e-3, 1e-3, NOT_MEASURED, NOT_MEASURED, NOT_MEASURED, 1e-2)
MAX_TICK = 0.1  # s: a longer gap between two ticks (a slow bus) counts as this for the acceleration limit


@dataclass(frozen=True)
class BaseConfig:
    left_id: int
    right_id: int
    wheel_radius: float  # m
    wheel_separation: float  # m, between the wheels' contact points
    left_inverted: bool = False
    right_inverted: bool = False
    max_linear: float = 1.0  # m/s
    max_angular: float = 2.0  # rad/s
    max_linear_accel: float = 1.0  # m/s^2
    max_angular_accel: float = 3.0  # rad/s^2
    timeout: float = 0.5  # s; 0 = never
    odom_frame: str = "odom"
    base_frame: str = "base_link"

    def check(self) -> None:
        if self.left_id == self.right_id:
            raise ValueError("--diff-drive: give two different IDs (left,right)")
        for name, value in (
            ("--wheel-radius", self.wheel_radius),
            ("--wheel-separation", self.wheel_separation),
            ("--max-linear", self.max_linear),
            ("--max-angular", self.max_angular),
            ("--max-linear-accel", self.max_linear_accel),
            ("--max-angular-accel", self.max_angular_accel),
        ):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} {value}: give a number > 0")
        if not (math.isfinite(self.timeout) and self.timeout >= 0):
            raise ValueError(f"command timeout {self.timeout}: give seconds >= 0 (0 = off)")
        top = rpm_to_rad_s(MAX_RPM) * self.wheel_radius
        if self.max_linear + self.max_angular * self.wheel_separation / 2 > top:
            raise ValueError(
                f"--max-linear/--max-angular: the wheels would need more than the controller's "
                f"{MAX_RPM} RPM ({top:.2f} m/s at this wheel radius)"
            )
        for frame in (self.odom_frame, self.base_frame):
            if not frame or frame.startswith("/"):
                raise ValueError(f"frame id {frame!r}: give a name without a leading '/'")


def _toward(value: float, target: float, step: float) -> float:
    return target if abs(target - value) <= step else value + math.copysign(step, target - value)


def _quaternion(yaw: float) -> Quaternion:
    return Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


def _diagonal(values: tuple[float, ...]) -> list[float]:
    matrix = [0.0] * 36
    for i, value in enumerate(values):
        matrix[i * 7] = value
    return matrix


class DiffDrive:
    def __init__(self, bridge: Bridge, config: BaseConfig) -> None:
        config.check()
        ids = list(bridge.ids)
        for wheel in (config.left_id, config.right_id):
            if wheel not in ids:
                raise ValueError(f"--diff-drive: ID {wheel} is not among the bridge's motors ({ids})")
        self.bridge = bridge
        self.config = config
        self.left = bridge.joints[ids.index(config.left_id)]
        self.right = bridge.joints[ids.index(config.right_id)]
        self.target = (0.0, 0.0)  # commanded (linear m/s, angular rad/s), clamped
        self.current = (0.0, 0.0)  # what the wheels are told now, within the acceleration limits
        self.commanded_at = -math.inf
        self.ticked_at: float | None = None
        self.moving = False
        # odometry
        self.x = self.y = self.yaw = 0.0
        self.linear = self.angular = 0.0
        self._last_wheels: tuple[float, float] | None = None  # wheel travel (m) at the last reading
        self.timeouts = 0

    # -- commands ------------------------------------------------------------------------
    def command(self, linear: float, angular: float, now: float) -> list[Action]:
        self.bridge.counters.commands += 1
        try:
            if self.bridge.estop_latched:
                raise Refused("cmd_vel: estop is latched; publish false on estop to accept commands again")
            if not (math.isfinite(linear) and math.isfinite(angular)):
                raise Refused(f"cmd_vel: linear.x {linear} / angular.z {angular} is not a number")
        except Refused as error:
            self.bridge.counters.refused += 1
            self.bridge.counters.last_refusal = str(error)
            raise
        c = self.config
        self.target = (max(-c.max_linear, min(c.max_linear, linear)), max(-c.max_angular, min(c.max_angular, angular)))
        self.commanded_at = now
        return []

    def tick(self, now: float) -> list[Action]:
        """Step the wheels toward the target within the acceleration limits (called after each reading)."""
        c = self.config
        dt = 0.0 if self.ticked_at is None else min(max(now - self.ticked_at, 0.0), MAX_TICK)
        self.ticked_at = now
        if self.bridge.estop_latched:  # released by the estop: start from standstill once it is unlatched
            self.current, self.target, self.moving = (0.0, 0.0), (0.0, 0.0), False
            return []
        target = self.target
        if c.timeout and now - self.commanded_at > c.timeout and target != (0.0, 0.0):
            target = self.target = (0.0, 0.0)
            self.timeouts += 1
            self.bridge.counters.timeouts += 1
        linear = _toward(self.current[0], target[0], c.max_linear_accel * dt)
        angular = _toward(self.current[1], target[1], c.max_angular_accel * dt)
        self.current = (linear, angular)
        rpms = self.wheel_rpms(linear, angular)
        actions: list[Action] = []
        if all(abs(rpm) < MIN_RPM for rpm in rpms):
            if self.moving:  # at zero speed: hold the position (see the module's TODO on Motor.stop)
                for joint in (self.left, self.right):
                    actions.append(Hold(joint.id))
                    joint.mode = "held"
                self.moving = False
            return actions
        self.moving = True
        for joint, rpm in zip((self.left, self.right), rpms, strict=True):
            joint.commanded_at = now  # the base has its own timeout: keep the bridge's from holding abruptly
            if joint.mode != "velocity" or rpm != joint.rpm or now - joint.sent_at >= RESEND_SAME:
                actions.append(Run(joint.id, rpm, self.bridge.ramp))
                joint.sent_at = now
            joint.mode, joint.rpm = "velocity", rpm
        return actions

    def wheel_rpms(self, linear: float, angular: float) -> tuple[float, float]:
        """Motor RPM (signed, on the wire's 0.1 grid) of each wheel for a base velocity."""
        c = self.config
        half = angular * c.wheel_separation / 2
        left = (linear - half) / c.wheel_radius * (-1.0 if c.left_inverted else 1.0)
        right = (linear + half) / c.wheel_radius * (-1.0 if c.right_inverted else 1.0)
        return round(rad_s_to_rpm(left), 1), round(rad_s_to_rpm(right), 1)

    # -- odometry ------------------------------------------------------------------------
    def _travel(self, joint: Joint, inverted: bool) -> float:
        assert joint.state is not None
        return deg_to_rad(joint.state.position) * self.config.wheel_radius * (-1.0 if inverted else 1.0)

    def _speed(self, joint: Joint, inverted: bool) -> float:
        assert joint.state is not None
        return rpm_to_rad_s(joint.signed_rpm()) * self.config.wheel_radius * (-1.0 if inverted else 1.0)

    def update_odometry(self) -> bool:
        """Integrate the latest readings of both wheels (False when either did not answer this round)."""
        c = self.config
        fresh = self.bridge.fresh
        if self.left not in fresh or self.right not in fresh:
            return False
        wheels = (self._travel(self.left, c.left_inverted), self._travel(self.right, c.right_inverted))
        if self._last_wheels is not None:
            d_left, d_right = wheels[0] - self._last_wheels[0], wheels[1] - self._last_wheels[1]
            distance = (d_left + d_right) / 2
            turn = (d_right - d_left) / c.wheel_separation
            heading = self.yaw + turn / 2  # the mid-point heading: exact for arcs to second order
            self.x += distance * math.cos(heading)
            self.y += distance * math.sin(heading)
            self.yaw = math.atan2(math.sin(self.yaw + turn), math.cos(self.yaw + turn))
        self._last_wheels = wheels
        v_left, v_right = self._speed(self.left, c.left_inverted), self._speed(self.right, c.right_inverted)
        self.linear = (v_left + v_right) / 2
        self.angular = (v_right - v_left) / c.wheel_separation
        return True

    def status(self, prefix: str) -> DiagnosticStatus:
        """The base's /diagnostics entry: what it is told, what it does, where it thinks it is."""
        values = {
            "target_linear_m_s": self.target[0],
            "target_angular_rad_s": self.target[1],
            "commanded_linear_m_s": self.current[0],
            "commanded_angular_rad_s": self.current[1],
            "measured_linear_m_s": self.linear,
            "measured_angular_rad_s": self.angular,
            "x_m": self.x,
            "y_m": self.y,
            "yaw_rad": self.yaw,
            "command_timeouts": self.timeouts,
        }
        moving = "moving" if self.moving else "standing (held)" if self.left.mode == "held" else "standing"
        return DiagnosticStatus(
            level=DIAGNOSTIC_WARN if self.bridge.estop_latched else DIAGNOSTIC_OK,
            name=f"{prefix}: base",
            message="released by estop (latched)" if self.bridge.estop_latched else moving,
            hardware_id=f"IDs {self.config.left_id} (left), {self.config.right_id} (right)",
            values=[KeyValue(k, f"{v:.4f}" if isinstance(v, float) else str(v)) for k, v in values.items()],
        )

    def odometry(self, stamp_ns: int) -> tuple[Odometry, TFMessage]:
        c = self.config
        header = Header(stamp=Time.from_ns(stamp_ns), frame_id=c.odom_frame)
        rotation = _quaternion(self.yaw)
        odom = Odometry(
            header=header,
            child_frame_id=c.base_frame,
            pose=PoseWithCovariance(Pose(Point(self.x, self.y, 0.0), rotation), _diagonal(POSE_COVARIANCE)),
            twist=TwistWithCovariance(
                Twist(Vector3(self.linear, 0.0, 0.0), Vector3(0.0, 0.0, self.angular)), _diagonal(TWIST_COVARIANCE)
            ),
        )
        transform = TransformStamped(
            header=Header(stamp=Time.from_ns(stamp_ns), frame_id=c.odom_frame),
            child_frame_id=c.base_frame,
            transform=Transform(Vector3(self.x, self.y, 0.0), _quaternion(self.yaw)),
        )
        return odom, TFMessage([transform])


def attach(node: Any, config: BaseConfig, stamped: bool = False, odom_tf: bool = True) -> DiffDrive:
    """Subscribe `cmd_vel` (Twist, or TwistStamped), publish `odom` and (unless `odom_tf` is False:
    --no-odom-tf, e.g. when robot_localization publishes it) `/tf` after every reading."""
    base = DiffDrive(node.bridge, config)
    participant = node.participant
    odom_topic = topic(node.namespace, "odom")
    odom_writer = participant.writer(odom_topic, Odometry)
    tf_writer = participant.writer("/tf", TFMessage) if odom_tf else None
    diagnostics_writer = participant.writer("/diagnostics", DiagnosticArray)
    next_status = [0.0]
    command_type = TwistStamped if stamped else Twist

    def on_data(reader: Any) -> None:
        for sample in reader.take(N=64):
            twist = sample.twist if isinstance(sample, TwistStamped) else sample
            if isinstance(twist, Twist):
                linear, angular = twist.linear.x, twist.angular.z
                node.call_on_bus_thread(lambda now, v=linear, w=angular: base.command(v, w, now), key="cmd_vel")

    participant.reader(topic(node.namespace, "cmd_vel"), command_type, on_data)

    def record(name: str, message: Any) -> None:
        if getattr(node, "recorder", None) is not None:
            node.recorder(name, message)

    def after_read(now: float) -> list[Action]:
        if base.update_odometry():
            odom, tf = base.odometry(time.time_ns())
            odom_writer.write(odom)
            record(odom_topic, odom)
            if tf_writer is not None:
                tf_writer.write(tf)
                record("/tf", tf)
        if now >= next_status[0]:  # 1 Hz, beside the bridge's own statuses
            next_status[0] = now + 1.0
            stamp = Header(stamp=Time.from_ns(time.time_ns()))
            array = DiagnosticArray(header=stamp, status=[base.status(node.prefix)])
            diagnostics_writer.write(array)
            record("/diagnostics", array)
        return base.tick(now)

    node.after_read.append(after_read)
    node.base = base  # its limits are parameters of the node (parameters.py)
    return base
