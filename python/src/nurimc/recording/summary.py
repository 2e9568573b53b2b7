"""What is in an MCAP recording (`nurimc replay FILE.mcap`, `nurimc inspect FILE.mcap`), and its
samples as CSV (`nurimc export FILE.mcap --csv OUT`).

Reads with the `mcap` package only: the JointState and Frame messages nurimc writes are decoded
here from their CDR bytes (the layout of sensor_msgs/JointState and nurimc_msgs/Frame, little-
or big-endian as the encapsulation header says), so neither a DDS stack nor rosbags is needed.
Files from other tools open too: their topics are listed and counted; only /joint_states-like
topics (schema sensor_msgs/msg/JointState) are exported.
"""

from __future__ import annotations

import contextlib
import csv
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

MAGIC = b"\x89MCAP"
JOINT_STATE = "sensor_msgs/msg/JointState"
FRAME = "nurimc_msgs/msg/Frame"


class RecordingError(ValueError):
    """The file is not an MCAP recording we can read; the message says what to do."""


def is_mcap(path: str | Path) -> bool:
    try:
        with open(path, "rb") as stream:
            return stream.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


class _Cdr:
    """A reader of XCDR1 plain data (what ROS 2 writes): alignment from the start of the data."""

    def __init__(self, data: bytes) -> None:
        if len(data) < 4:
            raise RecordingError("a message shorter than its CDR header")
        self.little = data[1] == 1  # 00 01: CDR_LE, 00 00: CDR_BE
        self.data, self.at = memoryview(data)[4:], 0

    def _take(self, fmt: str, size: int) -> Any:
        self.at += -self.at % size
        (value,) = struct.unpack_from(("<" if self.little else ">") + fmt, self.data, self.at)
        self.at += size
        return value

    def int32(self) -> int:
        value: int = self._take("i", 4)
        return value

    def uint32(self) -> int:
        value: int = self._take("I", 4)
        return value

    def uint8(self) -> int:
        value: int = self._take("B", 1)
        return value

    def float64(self) -> float:
        value: float = self._take("d", 8)
        return value

    def string(self) -> str:
        size = self.uint32()
        if size > len(self.data) - self.at:
            raise RecordingError("a string longer than its message")
        text = bytes(self.data[self.at : self.at + size]).rstrip(b"\0").decode("utf-8", "replace")
        self.at += size
        return text

    def count(self, item_size: int) -> int:
        n = self.uint32()
        if n * item_size > len(self.data) - self.at + 8:  # a length past the end: a broken message
            raise RecordingError("a sequence longer than its message")
        return n


@dataclass
class JointSample:
    t: float  # seconds (header stamp)
    names: list[str]
    position: list[float]
    velocity: list[float]
    effort: list[float]


def decode_joint_state(data: bytes) -> JointSample:
    cdr = _Cdr(data)
    sec, nanosec = cdr.int32(), cdr.uint32()
    cdr.string()  # frame_id
    names = [cdr.string() for _ in range(cdr.count(4))]
    values = [[cdr.float64() for _ in range(cdr.count(8))] for _ in range(3)]
    return JointSample(sec + nanosec / 1e9, names, *values)


def decode_frame(data: bytes) -> dict[str, Any]:
    cdr = _Cdr(data)
    sec, nanosec = cdr.int32(), cdr.uint32()
    direction = cdr.string()
    device_id = cdr.uint8()
    name = cdr.string()
    raw = bytes(cdr.uint8() for _ in range(cdr.count(1)))
    return {"t": sec + nanosec / 1e9, "dir": direction, "id": device_id, "name": name, "data": raw}


@dataclass
class TopicSummary:
    topic: str
    schema: str
    count: int = 0


@dataclass
class Summary:
    path: str
    topics: list[TopicSummary] = field(default_factory=list)
    start: float | None = None  # seconds (log time)
    end: float | None = None
    motors: list[str] = field(default_factory=list)  # joint names in /joint_states
    frame_ids: list[int] = field(default_factory=list)  # controller IDs in the raw frames
    messages: int = 0

    @property
    def seconds(self) -> float:
        return 0.0 if self.start is None or self.end is None else self.end - self.start

    def as_dict(self) -> dict[str, Any]:
        return {
            "file": self.path,
            "messages": self.messages,
            "start_s": self.start,
            "end_s": self.end,
            "duration_s": round(self.seconds, 6),
            "topics": [{"topic": t.topic, "schema": t.schema, "count": t.count} for t in self.topics],
            "motors": self.motors,
            "frame_ids": self.frame_ids,
        }


def _messages(path: str | Path) -> Iterator[tuple[Any, Any, Any]]:
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    broken = (McapError, struct.error, EOFError, ValueError, KeyError)
    with open(path, "rb") as stream:
        try:
            reader = make_reader(stream)
            yield from reader.iter_messages(log_time_order=False)
        except broken as error:
            if stream.seek(0) == 0 and stream.read(len(MAGIC)) != MAGIC:
                raise RecordingError(f"{path}: not an MCAP file (it does not start with the MCAP magic)") from None
            raise RecordingError(f"{path}: not a readable MCAP file ({error}); try nurimc repair-mcap {path}") from None


def _need_mcap() -> None:
    try:
        import mcap  # noqa: F401
    except ImportError:
        raise RecordingError("reading MCAP needs the mcap package: pip install mcap") from None


def summarize(path: str | Path) -> Summary:
    """Topics (schema, count), time span, motors (joint names) and controller IDs seen."""
    _need_mcap()
    summary = Summary(str(path))
    topics: dict[int, TopicSummary] = {}
    motors: dict[str, None] = {}
    frame_ids: set[int] = set()
    for schema, channel, message in _messages(path):
        entry = topics.get(channel.id)
        if entry is None:
            entry = topics[channel.id] = TopicSummary(channel.topic, schema.name if schema else "")
        entry.count += 1
        summary.messages += 1
        t = message.log_time / 1e9
        summary.start = t if summary.start is None else min(summary.start, t)
        summary.end = t if summary.end is None else max(summary.end, t)
        if entry.schema == JOINT_STATE:
            with contextlib.suppress(RecordingError, struct.error):  # counted even if its content is unreadable
                motors.update(dict.fromkeys(decode_joint_state(message.data).names))
        elif entry.schema == FRAME:
            with contextlib.suppress(RecordingError, struct.error):
                frame_ids.add(decode_frame(message.data)["id"])
    summary.topics = sorted(topics.values(), key=lambda t: t.topic)
    summary.motors = list(motors)
    summary.frame_ids = sorted(frame_ids)
    return summary


#: CSV columns per joint: (field of JointSample, column suffix with the unit)
COLUMNS = (("position", "position_rad"), ("velocity", "velocity_rad_s"), ("effort", "effort_A"))


def export_csv(path: str | Path, out: IO[str], topic: str | None = None) -> tuple[int, list[str]]:
    """Write the JointState samples as CSV: one row per sample, `time_s` (seconds from the first
    sample), then per joint its position (rad), velocity (rad/s) and effort (A: the motor's
    current). Returns (rows, joint names)."""
    _need_mcap()
    samples: list[JointSample] = []
    for schema, channel, message in _messages(path):
        if schema is None or schema.name != JOINT_STATE or (topic is not None and channel.topic != topic):
            continue
        try:
            samples.append(decode_joint_state(message.data))
        except (RecordingError, struct.error):
            continue
    if not samples:
        raise RecordingError(f"{path}: no {JOINT_STATE} samples" + (f" on {topic}" if topic else "") + " to export")
    samples.sort(key=lambda s: s.t)
    joints = list(dict.fromkeys(n for s in samples for n in s.names))
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["time_s", *(f"{j}.{suffix}" for j in joints for _, suffix in COLUMNS)])
    first = samples[0].t
    for s in samples:
        row: list[str] = [f"{s.t - first:.6f}"]
        for j in joints:
            at = s.names.index(j) if j in s.names else None
            for name, _ in COLUMNS:
                values: list[float] = getattr(s, name)
                row.append("" if at is None or at >= len(values) else repr(values[at]))
        writer.writerow(row)
    return len(samples), joints
