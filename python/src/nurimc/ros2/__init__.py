"""ROS 2 without ROS 2: the bus as ROS 2 topics over DDS (Eclipse Cyclone DDS), and the message types.

ROS 2 topics are DDS topics named `rt/<namespace>/<topic>` whose types are named
`<pkg>::msg::dds_::<Type>_` and serialized as CDR; a participant that follows those rules talks
to ROS 2 nodes without ROS 2 installed. Needs the extra: `pip install nurimc[ros2]`.
"""
