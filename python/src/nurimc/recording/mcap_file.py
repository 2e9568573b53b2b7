"""MCAP recordings of ROS 2 messages: `ros2msg` schemas, CDR data (what `ros2 bag` writes).

`McapRecorder` writes any message type of nurimc.ros2.msgs on a topic, and is also a bus
tracer (`record(direction, data)`): every whole frame the host sends or receives becomes a
`nurimc_msgs/msg/Frame` on /nurimc/frames, with its time and direction. The file opens in
Foxglove, PlotJuggler, `ros2 bag` (Humble with the mcap storage plugin, Jazzy by default),
the `mcap` tools and rosbags.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import IO

from cyclonedds.idl import IdlStruct
from mcap.writer import CompressionType, Writer

from .. import __version__
from ..protocol import StreamParser, build_frame
from ..ros2 import msgs

FRAMES_TOPIC = "/nurimc/frames"


class McapRecorder:
    """Write ROS 2 messages to an MCAP file; thread-safe; close() finishes the file (its index)."""

    def __init__(self, path: str | Path, compress: bool = True) -> None:
        self.path = Path(path)
        try:
            self._file: IO[bytes] = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        except OSError as error:
            raise ValueError(f"cannot write {self.path}: {error.strerror or error}") from None
        self._writer = Writer(self._file, compression=CompressionType.ZSTD if compress else CompressionType.NONE)
        self._writer.start(profile="ros2", library=f"nurimc {__version__}")
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], int] = {}
        self._lock = threading.Lock()
        self._parsers = {"tx": StreamParser(), "rx": StreamParser()}
        self._dropped = {"tx": 0, "rx": 0}
        self.counts: dict[str, int] = {}
        self._closed = False

    def _channel(self, topic: str, ros_type: str) -> int:
        key = (topic, ros_type)
        if key not in self._channels:
            if ros_type not in self._schemas:
                self._schemas[ros_type] = self._writer.register_schema(
                    name=ros_type, encoding="ros2msg", data=msgs.definition(ros_type).encode()
                )
            self._channels[key] = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=self._schemas[ros_type]
            )
        return self._channels[key]

    def write(self, topic: str, message: IdlStruct, log_time_ns: int | None = None) -> None:
        """One message on a topic, logged at `log_time_ns` (now if not given)."""
        t = time.time_ns() if log_time_ns is None else log_time_ns
        data = message.serialize()
        with self._lock:
            if self._closed:
                return
            channel = self._channel(topic, msgs.ros_type_of(message))
            self._writer.add_message(channel_id=channel, log_time=t, data=data, publish_time=t)
            self.counts[topic] = self.counts.get(topic, 0) + 1

    def joint_state(self, topic: str, message: msgs.JointState) -> None:
        self.write(topic, message, message.header.stamp.to_ns())

    # -- bus tracer: every frame sent and received --------------------------------------------
    def record(self, direction: str, data: bytes, log_time_ns: int | None = None) -> None:
        t = time.time_ns() if log_time_ns is None else log_time_ns  # given when converting a log
        parser = self._parsers[direction]
        for frame in parser.feed(data):
            dropped = parser.stats.dropped_bytes - self._dropped[direction]
            self._dropped[direction] = parser.stats.dropped_bytes
            message = msgs.Frame(
                stamp=msgs.Time.from_ns(t),
                direction=direction,
                id=frame.id,
                name=frame.name,
                # the bytes as they were: encode() would refuse a frame with an out-of-range value
                data=list(build_frame(frame.id, frame.SPEC.mode, frame.SPEC.layout.pack(*frame[1:]))),
                dropped_before=dropped,
            )
            self.write(FRAMES_TOPIC, message, t)

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._file.close()
