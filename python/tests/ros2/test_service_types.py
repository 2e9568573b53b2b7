"""The service types (interfaces.py) are those ROS 2 uses: the CDR bytes rclpy's serialize_message
gives (run in the ROS 2 venvs of `make ros-envs`), the RIHS01 hashes the wheels ship, and the
.srv/.msg files of our interface package (ros2/nurimc_msgs) match our DDS types field by field."""

from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
from cyclonedds.idl import IdlStruct

from nurimc.ros2 import interfaces as i
from nurimc.ros2 import msgs
from nurimc.ros2.definitions import definition
from nurimc.ros2.typehash import ros_name, type_description, type_hash

HERE = Path(__file__).parent
ROOT = HERE.parents[2]
PACKAGE = ROOT / "ros2" / "nurimc_msgs"
RELEASES = ["jazzy", "kilted"]


def ros_python(release: str) -> Path:
    root = Path(os.environ.get("NURIMC_ROS_ENVS", ROOT / "build"))
    python = root / f"ros-{release}" / "venv" / "bin" / "python"
    if not python.exists():
        pytest.skip(f"no ROS 2 {release} environment at {python}: `make ros-envs` makes it")
    return python


def shipped(release: str, srv_type: str) -> dict[str, str] | None:
    """type name -> RIHS01 hash, from the package's share/<pkg>/srv/<Name>.json (None: not installed)."""
    path = ros_python(release).parents[1] / "share" / f"{srv_type}.json"
    if not path.exists():
        return None
    return {t["type_name"]: t["hash_string"] for t in json.loads(path.read_text())["type_hashes"]}


@pytest.mark.parametrize("release", RELEASES)
def test_type_hashes_of_requests_responses_and_services_are_those_ros2_ships(release: str) -> None:
    checked = []
    for srv_type, (request, response) in i.SERVICE_TYPES.items():
        if srv_type.startswith("nurimc_msgs/"):
            continue
        hashes = shipped(release, srv_type)
        if hashes is None:
            assert srv_type.startswith("std_srvs/"), f"{srv_type}: rcl_interfaces is part of rclpy"
            continue
        assert type_hash(request) == hashes[f"{srv_type}_Request"], srv_type
        assert type_hash(response) == hashes[f"{srv_type}_Response"], srv_type
        assert i.service_type_hash(srv_type) == hashes[srv_type], srv_type
        checked.append(srv_type)
    assert len([t for t in checked if t.startswith("rcl_interfaces/")]) == 6


def samples() -> list[IdlStruct]:
    """Every request and response type, each field set to a value other than its default."""
    arrays = ([1, 255], [True, False, True], [1, -2, 1 << 40], [0.5, -1e-9], ["a", "bc"])
    full = i.ParameterValue(i.PARAMETER_DOUBLE, True, -5, 2.5, "x", *arrays)
    descriptor = i.ParameterDescriptor(
        "motor_1.ratio", i.PARAMETER_DOUBLE, "gear ratio", "0.1..6553.3", True, True,
        [i.FloatingPointRange(0.1, 6553.3, 0.1)], [i.IntegerRange(-3, 254, 7)],
    )  # fmt: skip
    result = i.SetParametersResult(True, "rate = 20.0")
    parameter = i.Parameter("rate", i.ParameterValue(i.PARAMETER_INTEGER, integer_value=7))
    return [
        i.ListParameters_Request(["motor_1", "b"], 3),
        i.ListParameters_Response(i.ListParametersResult(["rate", "motor_1.ratio"], ["motor_1"])),
        i.GetParameters_Request(["rate", "ids", ""]),
        i.GetParameters_Response([full, i.ParameterValue(), full]),
        i.SetParameters_Request([parameter, i.Parameter("x", full)]),
        i.SetParameters_Response([result, i.SetParametersResult(False, "no")]),
        i.SetParametersAtomically_Request([i.Parameter("x", full), parameter]),
        i.SetParametersAtomically_Response(result),
        i.DescribeParameters_Request(["rate"]),
        i.DescribeParameters_Response([descriptor, i.ParameterDescriptor("ids", i.PARAMETER_INTEGER_ARRAY)]),
        i.GetParameterTypes_Request(["a", "b"]),
        i.GetParameterTypes_Response([3, 0, 9]),
        i.Trigger_Request(),
        i.Trigger_Response(True, "estop: ID 1: control off (read back)"),
    ]


def rclpy_bytes(release: str, items: list[tuple[str, dict[str, Any]]]) -> list[bytes | None]:
    env = {**os.environ}
    env.pop("_ROS_WHEELS_BOOTSTRAP_COMPLETE", None)
    proc = subprocess.run(
        [str(ros_python(release)), str(HERE / "rclpy_node" / "serialize.py")],
        input=json.dumps([{"type": t, "value": v} for t, v in items]),
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return [bytes.fromhex(h) if h is not None else None for h in json.loads(proc.stdout.strip().splitlines()[-1])]


def same_but_padding(ours: bytes, theirs: bytes) -> bool:
    """Equal bytes, except where ours has padding (Cyclone writes zeros; Fast CDR leaves the buffer's
    bytes there), and the few bytes past the end that Fast CDR counts in (its size is an estimate)."""
    if not 0 <= len(theirs) - len(ours) <= 8:
        return False
    return all(a == b or a == 0 for a, b in zip(ours, theirs, strict=False))


@pytest.mark.parametrize("release", RELEASES)
def test_cdr_bytes_are_those_rclpy_serializes(release: str) -> None:
    """rclpy builds each sample from its fields and serializes it: our bytes match (padding aside),
    and our type reads rclpy's bytes back to the same values (which a shifted or swapped field fails)."""
    objects = samples()
    items = [(ros_name(type(o)), dataclasses.asdict(o)) for o in objects]  # type: ignore[call-overload]
    # the same bytes as std_srvs/Trigger, for a venv without std_srvs: Empty's, and SetParametersResult's
    items += [
        ("std_msgs/msg/Empty", {}),
        ("rcl_interfaces/msg/SetParametersResult", {"successful": True, "reason": "m"}),
    ]
    results = rclpy_bytes(release, items)
    checked = 0
    for message, theirs in zip(objects, results, strict=False):
        if theirs is None:
            assert ros_name(type(message)).startswith("std_srvs/"), ros_name(type(message))
            continue
        ours = message.serialize()
        assert same_but_padding(ours, theirs), f"{ros_name(type(message))}:\n ours  {ours.hex()}\n rclpy {theirs.hex()}"
        assert type(message).deserialize(theirs) == message, ros_name(type(message))
        checked += 1
    assert checked >= 12
    empty, result = results[-2:]
    assert empty is not None and same_but_padding(i.Trigger_Request().serialize(), empty)
    assert result is not None and same_but_padding(i.Trigger_Response(True, "m").serialize(), result)


def test_our_services_cdr_by_hand() -> None:
    """nurimc_msgs has no wheel: its bytes checked against the CDR rules directly."""
    request = i.ReadSetting_Request(7, "ratio").serialize().hex()
    assert request == "00010000" + "07000000" + "06000000" + b"ratio\0".hex()
    assert i.ResetPosition_Request(0).serialize().hex() == "00010000" + "00"
    answer = i.WriteSetting_Response(True, "ok", "12.5").serialize().hex()
    assert answer == "00010000" + "01000000" + "03000000" + b"ok\0".hex() + "00" + "05000000" + b"12.5\0".hex()


# -- the interface package ---------------------------------------------------------------------------

ROS_TYPE_IDS = {"bool": 15, "uint8": 3, "uint32": 7, "string": 17, "uint8[]": 3 + 144, "builtin_interfaces/Time": 1}


def fields_of(text: str) -> list[tuple[str, str]]:
    """(type, name) of each field of a .msg text or one side of a .srv (comments and constants left out)."""
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line and "=" not in line:
            kind, name = line.split()[:2]
            out.append((kind, name))
    return out


def described(data_type: type[IdlStruct]) -> list[tuple[int, str]]:
    return [(f["type"]["type_id"], f["name"]) for f in type_description(data_type)["type_description"]["fields"]]


@pytest.mark.parametrize("name", ["ReadSetting", "WriteSetting", "ResetPosition"])
def test_the_srv_files_are_our_types(name: str) -> None:
    request_text, response_text = (PACKAGE / "srv" / f"{name}.srv").read_text().split("---\n")
    request, response = i.SERVICE_TYPES[f"nurimc_msgs/srv/{name}"]
    for text, data_type in ((request_text, request), (response_text, response)):
        assert [(ROS_TYPE_IDS[k], n) for k, n in fields_of(text)] == described(data_type), name


def test_the_frame_msg_file_is_our_type_and_our_schema() -> None:
    text = (PACKAGE / "msg" / "Frame.msg").read_text()
    assert [(ROS_TYPE_IDS[k], n) for k, n in fields_of(text)] == described(msgs.Frame)
    own = definition("nurimc_msgs/msg/Frame").split("=" * 80)[0]  # the MCAP schema, less its Time section
    assert text == own


def test_the_package_builds_every_interface_file() -> None:
    package = ET.parse(PACKAGE / "package.xml").getroot()
    assert package.findtext("name") == "nurimc_msgs"
    assert package.findtext("member_of_group") == "rosidl_interface_packages"
    listed = re.findall(r'"((?:msg|srv)/\w+\.(?:msg|srv))"', (PACKAGE / "CMakeLists.txt").read_text())
    present = sorted(str(p.relative_to(PACKAGE)) for p in PACKAGE.glob("*/*.*") if p.suffix in (".msg", ".srv"))
    assert sorted(listed) == present and len(present) == 4
