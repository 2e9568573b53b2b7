"""Fixed sample messages of every type nurimc records, built from nurimc.ros2.msgs/base_msgs as
they are (Cyclone DDS types, or the plain dataclasses without it): the same values either way.

Imported by test_cdr_writer.py in-process and in a child without Cyclone DDS.
"""

from __future__ import annotations

import math
from typing import Any


def samples() -> list[tuple[str, Any]]:
    from nurimc.ros2 import base_msgs as b
    from nurimc.ros2 import msgs as m

    stamp = m.Time(sec=1_764_300_000, nanosec=123_456_789)
    header = m.Header(stamp=stamp, frame_id="base_link")
    covariance = [i / 7 for i in range(36)]
    return [
        ("time", m.Time(sec=-5, nanosec=999_999_999)),
        ("header", header),
        ("bool", m.Bool(data=True)),
        (
            "float64 multi array",
            m.Float64MultiArray(
                layout=m.MultiArrayLayout(dim=[m.MultiArrayDimension("joints", 2, 2)], data_offset=1),
                data=[1.5, -0.0, math.inf, 1e-300],
            ),
        ),
        (
            "joint state",
            m.JointState(
                header=header,
                name=["motor_1", "모터_2", "x"],
                position=[math.pi, -1.0, 0.0],
                velocity=[2.0, math.nan, 0.5],
                effort=[0.25, math.nan, -3.0],
            ),
        ),
        ("empty joint state", m.JointState()),
        (
            "diagnostics",
            m.DiagnosticArray(
                header=header,
                status=[
                    m.DiagnosticStatus(
                        level=m.DIAGNOSTIC_WARN,
                        name="nurimc: motor_1",
                        message="stale",
                        hardware_id="id 1",
                        values=[m.KeyValue("since", "1.5 s"), m.KeyValue("error", "")],
                    ),
                    m.DiagnosticStatus(level=m.DIAGNOSTIC_OK, name="bus", values=[]),
                ],
            ),
        ),
        (
            "frame",
            m.Frame(
                stamp=stamp, direction="tx", id=1, name="RequestPing", data=[0xFF, 0xFE, 1, 2, 0xA0], dropped_before=3
            ),
        ),
        ("frame with no bytes", m.Frame(stamp=stamp, direction="rx", id=255, name="", data=[], dropped_before=0)),
        (
            "odometry",
            b.Odometry(
                header=header,
                child_frame_id="base_footprint",
                pose=b.PoseWithCovariance(
                    pose=b.Pose(position=b.Point(1.0, 2.0, 0.0), orientation=b.Quaternion(0.0, 0.0, 0.6, 0.8)),
                    covariance=covariance,
                ),
                twist=b.TwistWithCovariance(
                    twist=b.Twist(linear=b.Vector3(0.3, 0.0, 0.0), angular=b.Vector3(0.0, 0.0, -0.2)),
                    covariance=covariance[::-1],
                ),
            ),
        ),
        (
            "tf",
            b.TFMessage(
                transforms=[
                    b.TransformStamped(
                        header=header,
                        child_frame_id="base_link",
                        transform=b.Transform(b.Vector3(1.0, 2.0, 3.0), b.Quaternion(0.0, 0.0, 0.0, 1.0)),
                    )
                ]
            ),
        ),
        (
            "twist stamped",
            b.TwistStamped(header=header, twist=b.Twist(linear=b.Vector3(0.1, 0.2, 0.3))),
        ),
    ]


if __name__ == "__main__":  # the child's side: each sample's bytes, one hex line each
    import sys

    from nurimc.ros2 import msgs

    for label, message in samples():
        sys.stdout.write(f"{label}\t{msgs.ros_type_of(message)}\t{message.serialize().hex()}\n")
