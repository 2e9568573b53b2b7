"""The ROS 2 package folder (ros2/nurimc_bringup): well-formed, and in step with the bridge.

No ROS 2 here: the files are read as XML, YAML and Python source. What is checked: every XML file
parses; the launch file's arguments are `nurimc ros2` options (flags are flags); each URDF's moving
joints are the bridge's joint map for its example (`--joint-names`), in order, and its ros2_control
block names the same joints and the bridge's default topics; the controllers' joints and wheel
geometry are the URDF's.
"""

from __future__ import annotations

import ast
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
import typer.main

from nurimc.cli.app import app
from nurimc.ros2.control_topics import DEFAULT_COMMANDS_TOPIC, DEFAULT_STATES_TOPIC
from nurimc.ros2.names import joint_names

PACKAGE = Path(__file__).parents[3] / "ros2" / "nurimc_bringup"
LAUNCH = PACKAGE / "launch" / "bridge.launch.py"
#: each robot description, the bridge's --joint-names for it, and its controllers file
ROBOTS = {
    "arm.urdf.xacro": ("shoulder,elbow", "arm_controllers.yaml"),
    "diff_base.urdf.xacro": ("left_wheel_joint,right_wheel_joint", "base_controllers.yaml"),
}


def settings_of(path: Path) -> dict[str, str | list[str]]:
    """`key: value` and `key: [a, b]` lines of a controllers file (the YAML it uses: no PyYAML here)."""
    text = path.read_text()
    assert "\t" not in text
    found: dict[str, str | list[str]] = {}
    for line in text.splitlines():
        match = re.match(r"^\s*([\w.]+):\s*([^#]*?)\s*(#.*)?$", line)
        if match and match.group(2):
            value = match.group(2)
            found[match.group(1)] = [v.strip() for v in value[1:-1].split(",")] if value.startswith("[") else value
    return found


def ros2_options() -> dict[str, Any]:
    """`nurimc ros2`'s options by name (typer's own click: looked at by attribute, not by class)."""
    ros2 = typer.main.get_command(app).commands["ros2"]  # type: ignore[attr-defined]
    return {name: p for p in ros2.params if getattr(p, "is_flag", None) is not None for name in p.opts}


def launch_tables() -> dict[str, Any]:
    """ARGUMENTS, FLAGS and GLOBAL of the launch file, read from its source (no `launch` needed)."""
    tree = ast.parse(LAUNCH.read_text())
    tables = {}
    for node in tree.body:
        if isinstance(node, ast.Assign | ast.AnnAssign):
            target = node.targets[0] if isinstance(node, ast.Assign) else node.target
            if isinstance(target, ast.Name) and target.id in ("ARGUMENTS", "FLAGS", "GLOBAL"):
                assert node.value is not None
                tables[target.id] = ast.literal_eval(node.value)
    return tables


@pytest.mark.parametrize(
    "path", sorted(p.relative_to(PACKAGE) for p in PACKAGE.rglob("*") if p.suffix in (".xml", ".xacro"))
)
def test_every_xml_file_is_well_formed(path: Path) -> None:
    ET.parse(PACKAGE / path)  # raises on a malformed file (e.g. "--" inside a comment)


def test_the_package_manifest() -> None:
    root = ET.parse(PACKAGE / "package.xml").getroot()
    assert root.get("format") == "3" and root.findtext("name") == PACKAGE.name
    assert root.findtext("export/build_type") == "ament_cmake"
    assert (PACKAGE / "CMakeLists.txt").read_text().count(f"project({PACKAGE.name} ") == 1


def test_the_launch_arguments_are_the_bridges_options() -> None:
    compile(LAUNCH.read_text(), str(LAUNCH), "exec")  # valid Python
    tables = launch_tables()
    options = ros2_options()
    arguments, flags, global_ = tables["ARGUMENTS"], tables["FLAGS"], tables["GLOBAL"]
    for name in arguments:
        if name in global_:
            continue
        option = options.get("--" + name.replace("_", "-"))
        assert option is not None, f"launch argument {name}: no such option of nurimc ros2"
        assert not option.is_flag, name
    for name in flags:
        option = options.get("--" + name.replace("_", "-"))
        assert option is not None and option.is_flag, f"launch flag {name}: not a flag of nurimc ros2"
    assert {"port", "baud"} <= set(global_) <= set(arguments)
    # and the options an integrator needs are all there
    wanted = {"ids", "namespace", "joint_names", "rate", "frame_prefix", "diff_drive", "torque_constants"}
    assert wanted <= set(arguments) and "no_odom_tf" in flags


@pytest.mark.parametrize("file", sorted(ROBOTS))
def test_the_urdf_joints_are_the_bridges_joint_map(file: str) -> None:
    names_option, controllers_file = ROBOTS[file]
    robot = ET.parse(PACKAGE / "urdf" / file).getroot()
    moving = [j.get("name") for j in robot.iterfind("joint") if j.get("type") != "fixed"]
    assert moving == joint_names(names_option, [1, 2])
    block = robot.find("ros2_control")
    assert block is not None
    assert [j.get("name") for j in block.iterfind("joint")] == moving
    params = {p.get("name"): p.text for p in block.iterfind("hardware/param")}
    defaults = {a.get("name"): a.get("default") for a in robot.iter("{http://www.ros.org/wiki/xacro}arg")}
    assert params["joint_commands_topic"] == "$(arg commands_topic)"
    assert params["joint_states_topic"] == "$(arg states_topic)"
    assert (defaults["commands_topic"], defaults["states_topic"]) == (DEFAULT_COMMANDS_TOPIC, DEFAULT_STATES_TOPIC)
    for joint in block.iterfind("joint"):  # every joint of a block has the same command interfaces
        commands = [c.get("name") for c in joint.iterfind("command_interface")]
        assert commands == [c.get("name") for c in block.iterfind("joint[1]/command_interface")]
    settings = settings_of(PACKAGE / "config" / controllers_file)
    if "joints" in settings:
        assert settings["joints"] == moving
    else:
        assert [*settings["left_wheel_names"], *settings["right_wheel_names"]] == moving
        properties = {p.get("name"): p.get("value", "") for p in robot.iter("{http://www.ros.org/wiki/xacro}property")}
        assert float(properties["wheel_radius"]) == float(str(settings["wheel_radius"]))
        assert float(properties["wheel_separation"]) == float(str(settings["wheel_separation"]))
        assert params["trigger_joint_command_threshold"] == "-1"  # wheels: velocity only (docs/ros2.md)
