"""`replay`/`inspect` summarise an MCAP recording, `export` writes its samples as CSV (issue 38,
Recordings); the CDR decoding here (no DDS stack) agrees with cyclonedds' own."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from nurimc.recording.mcap_file import McapRecorder
from nurimc.recording.summary import decode_frame, decode_joint_state, summarize
from nurimc.ros2 import msgs

from ..cli.inprocess import nurimc

START_NS = 1_700_000_000_000_000_000


def joint_state(i: int) -> msgs.JointState:
    return msgs.JointState(
        header=msgs.Header(stamp=msgs.Time.from_ns(START_NS + i * 20_000_000), frame_id=""),
        name=["left", "right"],
        position=[0.1 * i, -0.2 * i],
        velocity=[1.5, -1.5],
        effort=[0.3, 0.4],
    )


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    """Ten JointState samples 20 ms apart and three frames (IDs 1 and 2)."""
    path = tmp_path / "run.mcap"
    recorder = McapRecorder(path)
    for i in range(10):
        recorder.write("/joint_states", joint_state(i), log_time_ns=START_NS + i * 20_000_000)
    recorder.record("tx", _ping(1), log_time_ns=START_NS)
    recorder.record("tx", _ping(2), log_time_ns=START_NS + 1_000_000)
    recorder.record("tx", _ping(2), log_time_ns=START_NS + 2_000_000)
    recorder.close()
    return path


def _ping(device_id: int) -> bytes:
    from nurimc.protocol import RequestPing

    return RequestPing(device_id).encode()


def test_cdr_decoding_matches_cyclonedds() -> None:
    message = joint_state(3)
    sample = decode_joint_state(message.serialize())
    assert sample.names == ["left", "right"]
    assert sample.position == pytest.approx([0.3, -0.6]) and sample.velocity == [1.5, -1.5]
    assert sample.effort == pytest.approx([0.3, 0.4])
    assert sample.t == pytest.approx((START_NS + 60_000_000) / 1e9)
    frame = msgs.Frame(msgs.Time.from_ns(5), "rx", 7, "ping", list(b"\xff\xfe\x07"), 2)
    assert decode_frame(frame.serialize()) == {"t": 5e-9, "dir": "rx", "id": 7, "name": "ping", "data": b"\xff\xfe\x07"}


def test_summary_lists_topics_counts_span_and_motors(recording: Path) -> None:
    summary = summarize(recording)
    assert [(t.topic, t.schema, t.count) for t in summary.topics] == [
        ("/joint_states", "sensor_msgs/msg/JointState", 10),
        ("/nurimc/frames", "nurimc_msgs/msg/Frame", 3),
    ]
    assert summary.messages == 13 and summary.seconds == pytest.approx(0.18)
    assert summary.motors == ["left", "right"] and summary.frame_ids == [1, 2]


@pytest.mark.parametrize("command", ["replay", "inspect"])
def test_replay_and_inspect_summarise_an_mcap(recording: Path, command: str) -> None:
    done = nurimc(command, str(recording))
    assert done.code == 0, done.err
    assert "13 messages over 0.180 s" in done.out and "/joint_states" in done.out and "101" not in done.out
    assert "motors (joint names): left, right; controller IDs in the frames: 1, 2" in done.out
    as_json = json.loads(nurimc("--json", command, str(recording)).out)
    assert as_json["duration_s"] == pytest.approx(0.18) and as_json["motors"] == ["left", "right"]


def test_export_writes_one_row_per_sample_with_units(recording: Path, tmp_path: Path) -> None:
    target = tmp_path / "run.csv"
    done = nurimc("export", str(recording), "--csv", str(target))
    assert done.code == 0, done.err
    assert f"wrote {target}: 10 samples of 2 joint(s)" in done.out
    rows = list(csv.reader(target.open()))
    assert rows[0] == [
        "time_s",
        "left.position_rad", "left.velocity_rad_s", "left.effort_A",
        "right.position_rad", "right.velocity_rad_s", "right.effort_A",
    ]  # fmt: skip
    assert len(rows) == 11
    assert [float(r[0]) for r in rows[1:]] == pytest.approx([0.02 * i for i in range(10)])
    assert math.isclose(float(rows[4][1]), 0.3) and math.isclose(float(rows[4][4]), -0.6)


def test_export_to_stdout(recording: Path) -> None:
    done = nurimc("export", str(recording), "--csv", "-")
    assert done.code == 0 and done.out.splitlines()[0].startswith("time_s,left.position_rad")
    assert len(done.out.splitlines()) == 11


def test_export_without_samples_is_one_line_and_leaves_no_file(tmp_path: Path) -> None:
    path = tmp_path / "frames.mcap"
    recorder = McapRecorder(path)
    recorder.record("tx", _ping(1), log_time_ns=START_NS)
    recorder.close()
    target = tmp_path / "out.csv"
    done = nurimc("export", str(path), "--csv", str(target))
    assert done.code == 2 and len(done.errors) == 1 and "no sensor_msgs/msg/JointState samples" in done.err
    assert list(tmp_path.iterdir()) == [path]


@pytest.mark.parametrize(
    ("content", "says"),
    [(b"garbage\n", "not an MCAP file"), (None, "try nurimc repair-mcap")],
)
def test_broken_files_are_one_line(recording: Path, tmp_path: Path, content: bytes | None, says: str) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(content if content is not None else recording.read_bytes()[:600])
    for command in ("inspect", "export"):
        done = nurimc(command, str(bad), *(["--csv", str(tmp_path / "x.csv")] if command == "export" else []))
        assert done.code == 2 and len(done.errors) == 1 and says in done.err and "Traceback" not in done.err, done.err
