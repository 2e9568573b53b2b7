"""Launch the nurimc bridge (`nurimc ros2`) and, optionally, robot_state_publisher with a URDF.

    ros2 launch nurimc_bringup bridge.launch.py port:=/dev/ttyUSB0 baud:=115200 ids:=1,2 \
        joint_names:=shoulder,elbow namespace:=/arm

Every argument but `port`, `baud` and `description` is the `nurimc ros2` option of the same
name (`joint_names` -> `--joint-names`); an empty value leaves the bridge's default. The
package's tests check that each argument is an option of `nurimc ros2` (docs/ros2.md, "A package
to launch"). `description`: a URDF/xacro file for robot_state_publisher (empty: none), fed the
bridge's joint_states.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, OpaqueFunction
from launch.substitutions import LaunchConfiguration

#: argument -> (default, description); all but the first three are `nurimc ros2` options
ARGUMENTS = {
    "port": ("", "Serial port or URL of the bus: /dev/ttyUSB0, socket://host:port, sim://?ids=1,2"),
    "baud": ("", "Bus rate in bps (empty: nurimc's default)"),
    "description": ("", "URDF/xacro for robot_state_publisher (empty: none)"),
    "ids": ("", "Controller IDs in joint order: 1,2 (empty: those found)"),
    "namespace": ("/", "ROS 2 namespace of the topics"),
    "joint_names": ("", "One name per ID: shoulder,elbow (empty: motor_<ID>)"),
    "rate": ("", "joint_states per second (empty: 50)"),
    "command_timeout": ("", "Seconds without velocity commands before a turning motor holds"),
    "move_velocity": ("", "Speed of moves to position_commands, rad/s"),
    "node_name": ("", "Name of the bridge's node (empty: nurimc)"),
    "frame_prefix": ("", "Put before every frame id, e.g. robot1/"),
    "torque_constants": ("", "N·m/A per joint: effort in N·m (empty: amperes)"),
    "control_commands_topic": ("", "ros2_control topic-based interface: its joint_commands_topic"),
    "control_states_topic": ("", "ros2_control topic-based interface: its joint_states_topic"),
    "diff_drive": ("", "Mobile base: LEFT_ID,RIGHT_ID"),
    "wheel_radius": ("", "Wheel radius, m (with diff_drive)"),
    "wheel_separation": ("", "Distance between the wheels, m (with diff_drive)"),
    "mcap": ("", "Also record to this MCAP file"),
}
#: flags: "true" adds the option without a value
FLAGS = {
    "no_odom_tf": ("false", "Publish odom without the odom -> base transform"),
    "broadcast_read": ("false", "Read all motors with one broadcast request"),
    "cmd_vel_stamped": ("false", "cmd_vel is geometry_msgs/TwistStamped"),
}
GLOBAL = ("port", "baud", "description")


def _bridge(context, *args, **kwargs):
    def value(name):
        return LaunchConfiguration(name).perform(context).strip()

    command = ["nurimc"]
    for name in ("port", "baud"):
        if value(name):
            command += [f"--{name}", value(name)]
    command.append("ros2")
    for name in ARGUMENTS:
        if name not in GLOBAL and value(name):
            command += ["--" + name.replace("_", "-"), value(name)]
    for name in FLAGS:
        if value(name).lower() in ("true", "1", "yes"):
            command.append("--" + name.replace("_", "-"))
    actions = [ExecuteProcess(cmd=command, output="screen", sigterm_timeout="10")]
    description = value("description")
    if description:
        from launch_ros.actions import Node
        from launch_ros.parameter_descriptions import ParameterValue
        from launch.substitutions import Command

        namespace = value("namespace")
        actions.append(
            Node(
                package="robot_state_publisher",
                executable="robot_state_publisher",
                namespace=namespace if namespace != "/" else None,
                parameters=[
                    {
                        "robot_description": ParameterValue(
                            Command(["xacro ", description, " prefix:=", value("frame_prefix")]), value_type=str
                        ),
                        "frame_prefix": "",  # the URDF's links carry the prefix already (xacro prefix:=)
                    }
                ],
            )
        )
    return actions


def generate_launch_description():
    declared = [DeclareLaunchArgument(n, default_value=d, description=t) for n, (d, t) in ARGUMENTS.items()]
    declared += [DeclareLaunchArgument(n, default_value=d, description=t) for n, (d, t) in FLAGS.items()]
    return LaunchDescription([*declared, OpaqueFunction(function=_bridge)])
