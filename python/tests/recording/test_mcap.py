"""MCAP recordings: written with ros2msg schemas and CDR, read back equal by the mcap reader and by rosbags."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from nurimc.drivers.sync import Bus
from nurimc.procedures.group import read_states
from nurimc.protocol import BROADCAST_ID, RequestPing, StreamParser, build_frame
from nurimc.recording.mcap_file import FRAMES_TOPIC, McapRecorder
from nurimc.ros2 import msgs
from nurimc.ros2.bridge import Bridge

from ..ros2.rosbags_types import plain, typestore

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


class Bytes:
    """A second tracer: every byte, per direction, to compare with the recorded frames."""

    def __init__(self) -> None:
        self.seen = {"tx": b"", "rx": b""}

    def record(self, direction: str, data: bytes) -> None:
        self.seen[direction] += data

    def close(self) -> None:
        pass


class Both:
    def __init__(self, *tracers: Any) -> None:
        self.tracers = tracers

    def record(self, direction: str, data: bytes) -> None:
        for t in self.tracers:
            t.record(direction, data)

    def close(self) -> None:
        pass


def make_recording(path: Path) -> tuple[list[msgs.JointState], Bytes]:
    """Two simulated motors read five times, one moving, into `path`."""
    recorder, raw = McapRecorder(path), Bytes()
    bus = Bus.open("sim://?ids=1,2&baud=115200", baudrate=115200, tracer=Both(recorder, raw))
    bridge = Bridge([1, 2], ["a", "b"])
    procedures = [bus.motor(i).procedures for i in (1, 2)]
    bus.motor(2).run(60)
    written: list[Any] = []
    for _ in range(5):
        time.sleep(0.05)  # 60 RPM: 18 degrees between readings
        bridge.readings(bus.run(read_states(procedures)))
        message = bridge.joint_state(1_700_000_000_000_000_000 + len(written))
        assert message is not None
        recorder.joint_state("/joint_states", message)
        written.append(message)
    bus.close()
    recorder.close()
    return written, raw


def test_mcap_reader_gets_the_same_messages(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    written, raw = make_recording(path)
    states: list[msgs.JointState] = []
    frames: list[msgs.Frame] = []
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        assert reader.get_header().profile == "ros2"
        schemas = {s.name: s for s in summary.schemas.values()}
        assert set(schemas) == {"sensor_msgs/msg/JointState", "nurimc_msgs/msg/Frame"}
        assert all(s.encoding == "ros2msg" for s in schemas.values())
        assert schemas["sensor_msgs/msg/JointState"].data.decode().startswith("std_msgs/Header header\n")
        for schema, channel, message in reader.iter_messages():
            assert channel.message_encoding == "cdr"
            assert schema is not None
            decoded: Any = msgs.TYPES[schema.name].deserialize(message.data)
            if channel.topic == "/joint_states":
                assert message.log_time == decoded.header.stamp.to_ns()
                states.append(decoded)
            else:
                assert channel.topic == FRAMES_TOPIC
                assert message.log_time == decoded.stamp.to_ns()
                frames.append(decoded)
    assert states == written
    assert states[-1].velocity[1] > 0 and states[-1].position[1] > states[0].position[1]  # motor b turned
    for direction in ("tx", "rx"):
        recorded = [f for f in frames if f.direction == direction]
        assert b"".join(bytes(f.data) for f in recorded) == raw.seen[direction]  # every byte, in frames
        expected = StreamParser().feed(raw.seen[direction])
        assert [(f.id, f.name) for f in recorded] == [(m.id, m.name) for m in expected]
    assert {f.name for f in frames} >= {"request_position", "position_feedback", "accel_speed"}
    assert all(f.dropped_before == 0 for f in frames)


def test_rosbags_reads_the_same_values(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    written, _ = make_recording(path)
    ours: dict[str, list[Any]] = {"/joint_states": [], FRAMES_TOPIC: []}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            assert schema is not None
            ours[channel.topic].append(plain(msgs.TYPES[schema.name].deserialize(message.data)))
    theirs: dict[str, list[Any]] = {"/joint_states": [], FRAMES_TOPIC: []}
    with AnyReader([path], default_typestore=typestore()) as reader:  # the Frame type comes from the file
        assert {c.topic: c.msgtype for c in reader.connections} == {
            "/joint_states": "sensor_msgs/msg/JointState",
            FRAMES_TOPIC: "nurimc_msgs/msg/Frame",
        }
        for connection, _, data in reader.messages():
            theirs[connection.topic].append(plain(reader.deserialize(data, connection.msgtype)))
    assert theirs == ours
    assert theirs["/joint_states"] == [plain(m) for m in written]
    assert len(theirs[FRAMES_TOPIC]) >= 20


def test_record_command(tmp_path: Path) -> None:
    path = tmp_path / "cli.mcap"
    proc = subprocess.run(
        [
            *(NURIMC, "--port", "sim://?ids=1,3&baud=115200", "--baud", "115200"),
            *("record", "--mcap", str(path), "--ids", "1,3", "--rate", "20", "--seconds", "0.5"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NO_COLOR": "1", "COLUMNS": "200"},
    )
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {path}" in proc.stdout
    assert "(ends after 0.5 s, or Ctrl-C)" in proc.stdout and "(Ctrl-C ends)" not in proc.stdout  # as asked
    with path.open("rb") as stream:
        topics: dict[str, int] = {}
        for _, channel, message in make_reader(stream).iter_messages():
            topics[channel.topic] = topics.get(channel.topic, 0) + 1
            if channel.topic == "/joint_states":
                assert msgs.JointState.deserialize(message.data).name == ["motor_1", "motor_3"]
    assert 5 <= topics["/joint_states"] <= 12  # 20 per second for half a second
    assert topics[FRAMES_TOPIC] >= 4 * topics["/joint_states"]  # a request and an answer per motor per reading


def test_record_refuses_an_unwritable_file(tmp_path: Path) -> None:
    proc = subprocess.run(
        [NURIMC, "--port", "sim://?ids=1,", "record", "--mcap", str(tmp_path / "no" / "such" / "x.mcap")],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NO_COLOR": "1", "COLUMNS": "200"},
    )
    assert proc.returncode == 2 and "cannot write" in proc.stderr and "Traceback" not in proc.stderr


def test_record_without_ids_records_the_controllers_it_finds(tmp_path: Path) -> None:
    """Discovery's broadcast ping is recorded as sent (the codec would refuse to encode it)."""
    path = tmp_path / "found.mcap"
    proc = subprocess.run(
        [NURIMC, "--port", "sim://?ids=2,5", "record", "--mcap", str(path), "--rate", "20", "--seconds", "0.3"],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NO_COLOR": "1", "COLUMNS": "200"},
    )
    assert proc.returncode == 0, proc.stderr
    names: set[tuple[str, ...]] = set()
    sent: list[msgs.Frame] = []
    with path.open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages():
            if channel.topic == "/joint_states":
                names.add(tuple(msgs.JointState.deserialize(message.data).name))
            elif channel.topic == FRAMES_TOPIC:
                frame = msgs.Frame.deserialize(message.data)
                if frame.direction == "tx":
                    sent.append(frame)
    assert names == {("motor_2", "motor_5")}
    broadcast_ping = build_frame(BROADCAST_ID, RequestPing.SPEC.mode, b"")
    assert (sent[0].id, sent[0].name, bytes(sent[0].data)) == (BROADCAST_ID, "request_ping", broadcast_ping)
