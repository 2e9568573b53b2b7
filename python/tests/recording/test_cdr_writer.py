"""`nurimc record` without the ros2 extra: recording/cdr.py writes the bytes Cyclone DDS writes.

- every sample (and random messages of every type) serialised by cdr.py equals Cyclone DDS's bytes;
- in a child where Cyclone DDS cannot be imported, the message classes are plain dataclasses and
  their bytes are still the same;
- `nurimc record` run in such a child writes a file that rosbags and recording/summary.py read.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.recording import cdr
from nurimc.recording.summary import decode_frame, decode_joint_state, summarize
from nurimc.ros2 import msgs

from ..ros2.test_cdr import STRATEGIES  # the strategies that compare our bytes with rosbags'
from .cdr_samples import samples

cyclonedds = pytest.importorskip("cyclonedds")

HERE = Path(__file__).resolve().parent
PYTHON_DIR = HERE.parent.parent  # python/: the tests package is importable from here
ENV = {**os.environ, "NO_COLOR": "1", "COLUMNS": "200"}
#: a child in which `import cyclonedds` (and every cyclonedds.* module) raises ImportError; at its
#: exit it says on stderr whether any Cyclone DDS module was loaded after all
NO_DDS = (
    "import atexit, sys\n"
    "sys.modules['cyclonedds'] = None\n"
    "def _said():\n"
    "    loaded = [m for m, v in sys.modules.items() if m.startswith('cyclonedds') and v is not None]\n"
    "    sys.stderr.write(f'\\nDDS-LOADED:{loaded}\\n')\n"
    "atexit.register(_said)\n"
)


def no_dds(code: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", NO_DDS + code],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=ENV,
        cwd=PYTHON_DIR,
    )


def assert_no_dds(proc: subprocess.CompletedProcess[str]) -> None:
    assert "DDS-LOADED:[]" in proc.stderr, proc.stderr


# -- the same bytes as Cyclone DDS ---------------------------------------------------------------


@pytest.mark.parametrize("label", [label for label, _ in samples()])
def test_samples_serialise_as_cyclone_does(label: str) -> None:
    message = dict(samples())[label]
    assert type(message).__mro__[1] is cyclonedds.idl.IdlStruct  # the DDS path here
    ros_type = msgs.ros_type_of(message)
    assert cdr.serialize(ros_type, message) == message.serialize()


def test_a_joint_state_by_hand() -> None:
    """Alignment spelled out: header, the 8-byte alignment before the float64 sequences."""
    message = msgs.JointState(
        header=msgs.Header(stamp=msgs.Time(sec=1, nanosec=2), frame_id="b"),
        name=["m"],
        position=[1.0],
        velocity=[],
        effort=[],
    )
    expected = (
        b"\x00\x01\x00\x00"  # CDR_LE
        + b"\x01\x00\x00\x00\x02\x00\x00\x00"  # stamp
        + b"\x02\x00\x00\x00b\x00"  # frame_id "b" + NUL, then 2 bytes to align the uint32
        + b"\x00\x00"
        + b"\x01\x00\x00\x00"  # one name
        + b"\x02\x00\x00\x00m\x00"
        + b"\x00\x00"
        + b"\x01\x00\x00\x00"  # one position: the count at 28, the float64 at 32 (aligned to 8)
        + bytes.fromhex("000000000000f03f")
        + b"\x00\x00\x00\x00" * 2  # no velocities, no efforts
    )
    frame = msgs.Frame(stamp=msgs.Time(0, 0), direction="", id=7, name="", data=[9], dropped_before=1)
    expected_frame = [
        "00010000",  # CDR_LE
        "0000000000000000",  # stamp
        "0100000000",  # direction "" (its NUL)
        "07",  # id
        "00000100000000",  # name "": its length aligned to 4 from the start of the data
        "0000000100000009",  # data [9]: the count aligned to 4
        "00000001000000",  # dropped_before
    ]
    assert frame.serialize() == cdr.serialize("nurimc_msgs/msg/Frame", frame) == bytes.fromhex("".join(expected_frame))
    assert cdr.serialize("sensor_msgs/msg/JointState", message) == expected == message.serialize()


TEXT = st.text(max_size=10)
F64 = st.floats(width=64)  # NaN and the infinities too


@settings(max_examples=60, deadline=None)
@given(
    names=st.lists(TEXT, max_size=4),
    values=st.lists(st.lists(F64, max_size=4), min_size=3, max_size=3),
    stamp=st.tuples(st.integers(-(2**31), 2**31 - 1), st.integers(0, 2**32 - 1)),
    frame_id=TEXT,
)
def test_random_joint_states_serialise_as_cyclone_does(
    names: list[str], values: list[list[float]], stamp: tuple[int, int], frame_id: str
) -> None:
    message = msgs.JointState(
        header=msgs.Header(stamp=msgs.Time(*stamp), frame_id=frame_id),
        name=names,
        position=values[0],
        velocity=values[1],
        effort=values[2],
    )
    assert cdr.serialize("sensor_msgs/msg/JointState", message) == message.serialize()


@settings(max_examples=60, deadline=None)
@given(
    direction=st.sampled_from(["tx", "rx"]),
    device=st.integers(0, 255),
    name=TEXT,
    data=st.lists(st.integers(0, 255), max_size=20),
    dropped=st.integers(0, 2**32 - 1),
    level=st.integers(0, 3),
    pairs=st.lists(st.tuples(TEXT, TEXT), max_size=3),
)
def test_random_frames_and_diagnostics_serialise_as_cyclone_does(
    direction: str, device: int, name: str, data: list[int], dropped: int, level: int, pairs: list[tuple[str, str]]
) -> None:
    frame = msgs.Frame(msgs.Time(3, 4), direction, device, name, data, dropped)
    assert cdr.serialize("nurimc_msgs/msg/Frame", frame) == frame.serialize()
    status = msgs.DiagnosticStatus(level, name, direction, name, [msgs.KeyValue(k, v) for k, v in pairs])
    array = msgs.DiagnosticArray(msgs.Header(msgs.Time(5, 6), name), [status, status])
    assert cdr.serialize("diagnostic_msgs/msg/DiagnosticArray", array) == array.serialize()


@pytest.mark.parametrize("ros_type", sorted(msgs.TYPES))
@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_random_messages_of_every_type_serialise_as_cyclone_does(ros_type: str, data: st.DataObject) -> None:
    message = data.draw(STRATEGIES[ros_type])
    assert cdr.serialize(ros_type, message) == message.serialize()


def test_a_value_that_does_not_fit_is_a_clear_error() -> None:
    with pytest.raises(cdr.CdrError, match=r"nurimc_msgs/msg/Frame: a value does not fit"):
        cdr.serialize("nurimc_msgs/msg/Frame", msgs.Frame(id=300))
    with pytest.raises(cdr.CdrError, match=r"no ros2msg definition of nope_msgs/msg/Nope"):
        cdr.serialize("nope_msgs/msg/Nope", msgs.Bool())


def test_the_layout_comes_from_the_schema_text() -> None:
    """Constants (byte OK=0) and defaults (float64 w 1) are not fields; arrays keep their size."""
    status = cdr.layout("diagnostic_msgs/msg/DiagnosticStatus")["diagnostic_msgs/msg/DiagnosticStatus"]
    assert [(f.name, f.kind, f.count) for f in status] == [
        ("level", "byte", None),
        ("name", "string", None),
        ("message", "string", None),
        ("hardware_id", "string", None),
        ("values", "diagnostic_msgs/msg/KeyValue", -1),
    ]
    odometry = cdr.layout("nav_msgs/msg/Odometry")
    assert [f.name for f in odometry["geometry_msgs/msg/Quaternion"]] == ["x", "y", "z", "w"]
    covariance = odometry["geometry_msgs/msg/PoseWithCovariance"][1]
    assert (covariance.name, covariance.kind, covariance.count) == ("covariance", "float64", 36)


def test_the_type_hashes_are_those_computed_from_the_dds_types() -> None:
    from nurimc.ros2 import base_msgs
    from nurimc.ros2.typehash import ros_name, type_hash

    classes = [*msgs.TYPES.values()]
    classes += [c for c in vars(base_msgs).values() if isinstance(c, type) and c.__module__ == base_msgs.__name__]
    assert {ros_name(c): type_hash(c) for c in classes} == cdr.TYPE_HASHES


# -- without Cyclone DDS -------------------------------------------------------------------------


def test_without_cyclone_the_plain_classes_write_the_same_bytes() -> None:
    proc = no_dds(
        "import runpy\n"
        "from nurimc.ros2 import msgs\n"
        "assert msgs.JointState.__mro__[1].__module__ == 'nurimc.recording.cdr', msgs.JointState.__mro__\n"
        f"runpy.run_path({str(HERE / 'cdr_samples.py')!r}, run_name='__main__')\n"
    )
    assert proc.returncode == 0, proc.stderr
    assert_no_dds(proc)
    theirs = {}
    for line in proc.stdout.splitlines():
        label, ros_type, data = line.split("\t")
        theirs[label] = (ros_type, bytes.fromhex(data))
    ours = {label: (msgs.ros_type_of(m), m.serialize()) for label, m in samples()}
    assert theirs == ours


def test_record_writes_a_readable_file_without_cyclone(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    args = ["nurimc", "--port", "sim://?ids=1,2&baud=115200", "--baud", "115200"]
    args += ["record", "--mcap", str(path), "--ids", "1,2", "--rate", "20", "--seconds", "0.5"]
    proc = no_dds(f"from nurimc.cli.app import main\nsys.argv = {args!r}\nmain()\n")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert_no_dds(proc)
    assert "wrote" in proc.stdout and "on /joint_states" in proc.stdout

    summary = summarize(path)  # recording/summary.py: the mcap package only
    counts = {t.topic: t.count for t in summary.topics}
    assert counts["/joint_states"] >= 1 and counts["/nurimc/frames"] >= 4
    assert summary.motors == ["motor_1", "motor_2"] and summary.frame_ids == [1, 2]

    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        reader = make_reader(stream)
        channels = reader.get_summary().channels  # type: ignore[union-attr]
        hashes = {c.topic: c.metadata.get("topic_type_hash") for c in channels.values()}
        assert hashes == {
            "/joint_states": cdr.TYPE_HASHES["sensor_msgs/msg/JointState"],
            "/nurimc/frames": cdr.TYPE_HASHES["nurimc_msgs/msg/Frame"],
        }
        for schema, channel, message in reader.iter_messages():
            assert schema is not None
            assert schema.data.decode() == msgs.definition(schema.name)
            # the bytes decode back to the values, and Cyclone writes the same bytes for those values
            if channel.topic == "/joint_states":
                sample = decode_joint_state(message.data)
                again = msgs.JointState(
                    header=msgs.Header(stamp=msgs.Time.from_ns(message.log_time)),
                    name=sample.names,
                    position=sample.position,
                    velocity=sample.velocity,
                    effort=sample.effort,
                )
                assert again.serialize() == message.data
            else:
                frame = decode_frame(message.data)
                again_frame = msgs.Frame(
                    msgs.Time.from_ns(message.log_time), frame["dir"], frame["id"], frame["name"], list(frame["data"])
                )
                assert again_frame.serialize()[:-4] == message.data[:-4]  # all but dropped_before

    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as bag:  # an independent reader: rosbags
        seen: dict[str, int] = {}
        for connection, _t, raw in bag.messages():
            decoded: Any = bag.deserialize(raw, connection.msgtype)
            seen[connection.topic] = seen.get(connection.topic, 0) + 1
            if connection.topic == "/joint_states":
                assert list(decoded.name) == ["motor_1", "motor_2"]
                assert all(math.isfinite(v) for v in decoded.position)
            else:
                assert decoded.direction in ("tx", "rx") and decoded.id in (1, 2)
                assert bytes(decoded.data)[:2] == b"\xff\xfe"
    assert seen == counts

    # repair-mcap needs no DDS stack either: a complete file is copied whole
    fixed = tmp_path / "fixed.mcap"
    repair = ["nurimc", "repair-mcap", str(path), "--out", str(fixed)]
    proc = no_dds(f"from nurimc.cli.app import main\nsys.argv = {repair!r}\nmain()\n")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert_no_dds(proc)
    assert f"copied {summary.messages} messages" in proc.stdout
    assert {t.topic: t.count for t in summarize(fixed).topics} == counts


def test_record_without_mcap_says_what_to_install(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    args = ["nurimc", "--port", "sim://?ids=1", "record", "--mcap", str(path), "--seconds", "0.2"]
    proc = no_dds(f"sys.modules['mcap'] = None\nfrom nurimc.cli.app import main\nsys.argv = {args!r}\nmain()\n")
    assert proc.returncode != 0
    assert "pip install 'nurimc[record]'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not path.exists()
