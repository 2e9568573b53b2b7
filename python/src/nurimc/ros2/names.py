"""ROS 2 names -> DDS topic names, and the checks ROS 2 applies to a namespace and a topic.

A ROS 2 topic `/ns/joint_states` is the DDS topic `rt/ns/joint_states` (`rt` = ROS topic).
The rules checked are ROS 2's: a namespace is absolute, its tokens are letters, digits and
underscores and do not start with a digit, no empty token, no trailing slash.
"""

from __future__ import annotations

import re

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
MAX_NAMESPACE = 200  # leaves room for the topic name within DDS's practical limits


class NameError_(ValueError):
    """A namespace or name that ROS 2 would refuse (the message says which rule)."""


def namespace(text: str | None) -> str:
    """Normalize and check a namespace: "" or "/" -> "/", "robot" -> "/robot", "/a/b" stays."""
    if not text or text == "/":
        return "/"
    ns = text if text.startswith("/") else "/" + text
    if ns.endswith("/"):
        raise NameError_(f"namespace {text!r}: must not end with '/'")
    if len(ns) > MAX_NAMESPACE:
        raise NameError_(f"namespace {text!r}: longer than {MAX_NAMESPACE} characters")
    for token in ns[1:].split("/"):
        if not token:
            raise NameError_(f"namespace {text!r}: empty part ('//')")
        if not _TOKEN.match(token):
            raise NameError_(
                f"namespace {text!r}: part {token!r} must be letters, digits and '_' and not start with a digit"
            )
    return ns


def topic(ns: str, name: str) -> str:
    """The ROS 2 name of a topic: relative names go under the namespace, "/x" stays absolute."""
    if name.startswith("/"):
        return name
    return f"/{name}" if ns == "/" else f"{ns}/{name}"


def topic_option(option: str, text: str, ns: str) -> str:
    """A topic name given on the command line (relative: under the namespace), checked as ROS 2 does."""
    if not text or text.endswith("/"):
        raise NameError_(f"{option} {text!r}: give a topic name such as robot_joint_commands or /robot_joint_commands")
    full = topic(ns, text)
    for token in full[1:].split("/"):
        if not _TOKEN.match(token):
            raise NameError_(
                f"{option} {text!r}: part {token!r} must be letters, digits and '_' and not start with a digit"
            )
    return full


def dds_topic(ros_name: str) -> str:
    """ "/ns/joint_states" -> "rt/ns/joint_states" (how ROS 2 names the DDS topic)."""
    if not ros_name.startswith("/"):
        raise NameError_(f"topic {ros_name!r}: give the full name (starting with '/')")
    return "rt" + ros_name


def joint_names(text: str | None, ids: list[int]) -> list[str]:
    """`--joint-names a,b` (one per ID, distinct, non-empty) or motor_<ID> for each ID."""
    if not text:
        return [f"motor_{i}" for i in ids]
    names = [n.strip() for n in text.split(",")]
    if len(names) != len(ids):
        raise NameError_(f"--joint-names gives {len(names)} names for {len(ids)} motors: give one per ID")
    if any(not n for n in names):
        raise NameError_("--joint-names: a name is empty")
    if len(set(names)) != len(names):
        raise NameError_("--joint-names: the names must differ")
    return names
