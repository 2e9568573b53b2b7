"""The generated Cyclone DDS configuration: ROS 2's discovery variables, kept peers, quiet logs."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest
from cyclonedds.domain import Domain

from nurimc.ros2.dds import FAST_DDS_NAME_MATCHING, domain_config
from nurimc.ros2.ddsconfig import generated_config


def parsed(environ: dict[str, str]) -> ET.Element:
    return ET.fromstring(generated_config(environ)).find("Domain")  # type: ignore[return-value]


def peers(domain: ET.Element) -> list[str]:
    return [p.get("address", "") for p in domain.iterfind("Discovery/Peers/Peer")]


def test_by_default_multicast_stays_on_peers_are_kept_and_logs_are_quiet() -> None:
    domain = parsed({})
    assert domain.find("General") is None  # Cyclone's defaults: multicast on every usable interface
    assert domain.findtext("Discovery/InitialLocatorPruneDelay") == "inf"
    assert domain.findtext("Discovery/SPDPInterval") == "1 s"  # a late node is found within a second
    assert domain.findtext("Tracing/Verbosity") == "severe"
    assert domain.findtext("Internal/GenerateKeyhash") == "true"  # Fast DDS sees a stopped bridge go at once
    assert peers(domain) == []


def test_static_peers_as_ros2_defines_them() -> None:
    domain = parsed({"ROS_STATIC_PEERS": " 192.168.1.10; robot2.local;;fe80::1%eth0 "})
    assert peers(domain) == ["192.168.1.10", "robot2.local", "fe80::1%eth0"]
    assert domain.findtext("Discovery/ParticipantIndex") == "auto"  # unicast peers need well-known ports
    assert domain.findtext("General/AllowMulticast") is None  # SUBNET: multicast as well


def test_localhost_range_keeps_dds_on_loopback() -> None:
    domain = parsed({"ROS_AUTOMATIC_DISCOVERY_RANGE": "localhost", "ROS_STATIC_PEERS": "10.0.0.2"})
    assert domain.find("General/Interfaces/NetworkInterface").get("address") == "127.0.0.1"  # type: ignore[union-attr]
    assert domain.findtext("General/AllowMulticast") == "false"
    assert peers(domain) == ["127.0.0.1", "10.0.0.2"]


def test_off_range_asks_only_the_static_peers() -> None:
    domain = parsed({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF", "ROS_STATIC_PEERS": "10.0.0.2"})
    assert domain.findtext("General/AllowMulticast") == "false"
    assert peers(domain) == ["10.0.0.2"]
    assert parsed({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"}).find("General") is None


@pytest.mark.parametrize(
    ("environ", "why"),
    [
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LAN"}, "ROS_AUTOMATIC_DISCOVERY_RANGE='LAN': give one of SUBNET"),
        ({"ROS_STATIC_PEERS": "10.0.0.1;<evil/>"}, "ROS_STATIC_PEERS: '<evil/>' is not an address"),
        ({"ROS_STATIC_PEERS": "a b"}, "is not an address or host name"),
    ],
)
def test_bad_variables_are_refused_with_what_to_give(environ: dict[str, str], why: str) -> None:
    with pytest.raises(ValueError, match=why.replace("(", r"\(")):
        generated_config(environ)


def test_the_user_configuration_comes_after_ours_and_the_compatibility_setting_last() -> None:
    user = "<CycloneDDS><Domain Id='any'><General><AllowMulticast>true</AllowMulticast></General></Domain></CycloneDDS>"
    parts = domain_config({"CYCLONEDDS_URI": user, "ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}).split(",")
    assert parts == [generated_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}), user, FAST_DDS_NAME_MATCHING]


@pytest.mark.parametrize(
    "environ",
    [
        {},
        {"ROS_STATIC_PEERS": "127.0.0.1;localhost"},
        {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"},
        {"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"},
        {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"},
    ],
)
def test_cyclone_takes_every_generated_configuration(environ: dict[str, str]) -> None:
    domain = Domain(231, domain_config(environ))  # raises if Cyclone refuses a setting
    domain.__del__()
