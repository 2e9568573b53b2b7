"""MCAP recordings of ROS 2 messages: `ros2msg` schemas, CDR data (what `ros2 bag` writes).

`McapRecorder` writes any message type of nurimc.ros2.msgs on a topic, and is also a bus
tracer (`record(direction, data)`): every whole frame the host sends or receives becomes a
`nurimc_msgs/msg/Frame` on /nurimc/frames, with its time and direction. The file opens in
Foxglove, PlotJuggler, `ros2 bag` (Humble with the mcap storage plugin, Jazzy by default),
the `mcap` tools and rosbags.

Writing needs only the `mcap` package: the CDR bytes come from recording/cdr.py, with or without
Cyclone DDS installed (its bytes are Cyclone DDS's for the same message, tests compare them, and
it is faster: benchmarks/cdr_writer.py); without Cyclone DDS the messages are ros2/msgs.py's plain
dataclasses, and the type hashes come from cdr.TYPE_HASHES.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from .. import __version__
from ..protocol import StreamParser, wire_bytes
from ..ros2 import msgs
from .cdr import TYPE_HASHES, serialize
from .checkpoint import CheckpointFailed, CheckpointStream, checkpoint, finish

FRAMES_TOPIC = "/nurimc/frames"
_INFINITE = "\n    sec: 9223372036\n    nsec: 854775807"  # RMW_DURATION_INFINITE, as rosbag2 writes it
#: rosbag2's YAML of the QoS every topic is offered with here: ROS 2's default profile (ros2/dds.py)
OFFERED_QOS = (
    "- history: keep_last\n  depth: 10\n  reliability: reliable\n  durability: volatile\n"
    f"  deadline:{_INFINITE}\n  lifespan:{_INFINITE}\n  liveliness: automatic\n"
    f"  liveliness_lease_duration:{_INFINITE}\n  avoid_ros_namespace_conventions: false"
)


class McapRecorder:
    """Write ROS 2 messages to an MCAP file; thread-safe; close() finishes the file (its index)."""

    def __init__(self, path: str | Path, compress: bool = True, checkpoint_seconds: float = 1.0) -> None:
        """`checkpoint_seconds`: how often the file on disk is made complete (0 = only at close);
        a crash (kill -9, power loss) loses at most that much."""
        if not (math.isfinite(checkpoint_seconds) and 0 <= checkpoint_seconds <= 3600):
            raise ValueError(f"checkpoint interval {checkpoint_seconds} s: use 0..3600 seconds (0 = only at the end)")
        self.path = Path(path)
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        except OSError as error:
            raise ValueError(f"cannot write {self.path}: {error.strerror or error}") from None
        self._stream = CheckpointStream(fd)
        # chunk_size: no chunk closes on size before the checkpoint closes it (a second of frames is far less)
        self._writer = Writer(
            self._stream,  # type: ignore[arg-type]  # a file-like object: write, tell, flush
            chunk_size=64 << 20,
            compression=CompressionType.ZSTD if compress else CompressionType.NONE,
        )
        self._writer.start(profile="ros2", library=f"nurimc {__version__}")
        checkpoint(self._writer, self._stream, sync=False)  # a valid (empty) file from the start
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], int] = {}
        self._lock = threading.Lock()
        self._parsers = {"tx": StreamParser(), "rx": StreamParser()}
        self._dropped = {"tx": 0, "rx": 0}
        self.counts: dict[str, int] = {}
        self._closed = False
        #: why the recording stopped writing (disk full...), one line; None while all is well
        self.failed: str | None = None
        #: called once (from the checkpoint thread) when it fails: the caller ends the recording
        self.on_failure: Callable[[str], None] | None = None
        self._stop = threading.Event()
        self._checkpoints: threading.Thread | None = None
        if checkpoint_seconds:
            self._checkpoints = threading.Thread(
                target=self._checkpoint_every, args=(checkpoint_seconds,), name="nurimc-mcap-checkpoint", daemon=True
            )
            self._checkpoints.start()

    def _checkpoint_every(self, seconds: float) -> None:
        while not self._stop.wait(seconds):
            with self._lock:
                if self._closed:
                    return
                try:
                    checkpoint(self._writer, self._stream, sync=False)
                except OSError as error:  # disk full: stop writing at once, the file as it was
                    self._fail(error)
                    break
                fd = self._stream.fd
            # fsync outside the lock: a slow disk must not hold up the messages being recorded
            # (after a close in between, fsync of a closed or reused descriptor does no harm)
            with contextlib.suppress(OSError):
                os.fsync(fd)
        if self.failed is not None and self.on_failure is not None:
            self.on_failure(self.failed)

    def _fail(self, error: OSError) -> None:
        """Under the lock: no more writes; say why in one line."""
        self._closed = True
        self._stop.set()
        restored = not isinstance(error, CheckpointFailed) or error.restored
        after = (
            "the file is complete up to its last checkpoint"
            if restored
            else f"the file may be torn: run nurimc repair-mcap {self.path}"
        )
        self.failed = f"cannot write {self.path}: {error.strerror or error}; {after}"

    def _channel(self, topic: str, ros_type: str, data_type: type[Any] | None = None) -> int:
        key = (topic, ros_type)
        if key not in self._channels:
            if ros_type not in self._schemas:
                self._schemas[ros_type] = self._writer.register_schema(
                    name=ros_type, encoding="ros2msg", data=msgs.definition(ros_type).encode()
                )
            # as rosbag2 (Jazzy) writes a channel: the QoS offered on the topic and the type's RIHS01 hash
            metadata = {"offered_qos_profiles": OFFERED_QOS}
            hash_ = TYPE_HASHES.get(ros_type) or (_type_hash(data_type) if data_type is not None else None)
            if hash_ is not None:
                metadata["topic_type_hash"] = hash_
            self._channels[key] = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=self._schemas[ros_type], metadata=metadata
            )
        return self._channels[key]

    def write(self, topic: str, message: Any, log_time_ns: int | None = None) -> None:
        """One message (a nurimc.ros2.msgs or base_msgs instance) on a topic, logged at `log_time_ns`
        (now if not given)."""
        t = time.time_ns() if log_time_ns is None else log_time_ns
        ros_type = msgs.ros_type_of(message)
        data = serialize(ros_type, message)
        with self._lock:
            if self._closed:
                return
            channel = self._channel(topic, ros_type, type(message))
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
                data=list(wire_bytes(frame)),
                dropped_before=dropped,
            )
            self.write(FRAMES_TOPIC, message, t)

    def close(self) -> None:
        """Finish the file. A failure (disk full) is not raised: `failed` says it in one line."""
        with self._lock:
            if self._stream.fd < 0:
                return
            try:
                if not self._closed:
                    self._closed = True
                    self._stop.set()
                    finish(self._writer, self._stream)
            except OSError as error:
                self._fail(error)
            finally:
                os.close(self._stream.fd)
                self._stream.fd = -1


def _type_hash(data_type: Any) -> str | None:
    """The RIHS01 hash of a type not in cdr.TYPE_HASHES: computed from its Cyclone DDS type."""
    try:
        from ..ros2.typehash import type_hash
    except ImportError:  # no Cyclone DDS: a type outside the table has no hash in the file
        return None
    return type_hash(data_type)
