"""The Cyclone DDS configuration the bridge generates: ROS 2's discovery variables, kept peers, quiet logs.

Cyclone DDS reads its configuration from XML fragments applied in order (later wins). The
bridge's domain gets, in this order (dds.domain_config):

1. What ROS 2 itself would do with its environment (as rmw_cyclonedds_cpp does; docs/ros2.md,
   "Several machines"):
   - `ROS_AUTOMATIC_DISCOVERY_RANGE`: `SUBNET` (the default when unset) leaves multicast on;
     `LOCALHOST` keeps DDS on the loopback interface (multicast off, the peer 127.0.0.1);
     `OFF` turns automatic discovery off (no multicast; only `ROS_STATIC_PEERS` are asked);
     `SYSTEM_DEFAULT` leaves Cyclone's own defaults alone.
   - `ROS_STATIC_PEERS`: addresses or host names separated by `;`, each asked directly (unicast),
     in addition to the automatic range.
   With unicast peers, the participant index is automatic: peers find each other on the
   well-known ports of indices 0..MAX_PARTICIPANT_INDEX.
2. Our own settings: peers that have not answered are never dropped
   (`Discovery/InitialLocatorPruneDelay` = inf: Cyclone's default drops them after 30 s, so a
   laptop joining a minute later was never found) and are announced to every second
   (`Discovery/SPDPInterval` = 1 s; Cyclone's default, 30 s, found a late laptop only 15 s or
   more after it started, tests/ros2/test_netns.py); Cyclone's log is kept to severe errors
   (`Tracing/Verbosity` = severe: a hostile or broken network cannot fill a disk or a terminal);
   discovery data carries the key hash of the participant or endpoint it is about
   (`Internal/GenerateKeyhash` = true): Fast DDS 2.14 and 3.2 (Jazzy, Kilted) take the identity of a
   participant or endpoint that says goodbye only from that hash, so without it a stopped bridge's
   readers stayed matched in every Fast DDS node until its lease ran out (10 s), and a bridge
   restarted within that time lost the first command (docs/ros2.md, "Restarts and start-up").
3. The user's `CYCLONEDDS_URI`, which overrides any of the above.
4. The Fast DDS 3 compatibility setting (dds.FAST_DDS_NAME_MATCHING).
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from xml.sax.saxutils import quoteattr

RANGES = ("SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT")
SPDP_INTERVAL = "1 s"  # how often the participant announces itself (to every peer): a late node is found within it
MAX_PARTICIPANT_INDEX = 32  # as rmw_cyclonedds_cpp: enough for a robot's processes on one host
#: a host name or an IPv4/IPv6 address (no spaces, quotes or angle brackets: it goes into XML)
PEER = re.compile(r"^[A-Za-z0-9_.:%\-\[\]]{1,253}$")


def discovery_range(environ: Mapping[str, str]) -> str:
    text = environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if not text:
        return "SUBNET"
    if text not in RANGES:
        raise ValueError(
            f"ROS_AUTOMATIC_DISCOVERY_RANGE={environ['ROS_AUTOMATIC_DISCOVERY_RANGE']!r}: give one of "
            f"{', '.join(RANGES)} (or leave it unset: SUBNET)"
        )
    return text


def static_peers(environ: Mapping[str, str]) -> list[str]:
    peers = []
    for item in environ.get("ROS_STATIC_PEERS", "").split(";"):
        peer = item.strip()
        if not peer:
            continue
        if not PEER.match(peer):
            raise ValueError(
                f"ROS_STATIC_PEERS: {peer!r} is not an address or host name; give them separated by ';' "
                "(e.g. 192.168.1.10;robot2.local)"
            )
        peers.append(peer)
    return peers


def generated_config(environ: Mapping[str, str] | None = None) -> str:
    """Our part of the configuration (1 and 2 above), as one XML fragment."""
    env = os.environ if environ is None else environ
    where = discovery_range(env)
    peers = static_peers(env)
    general = ""
    discovery = f"<InitialLocatorPruneDelay>inf</InitialLocatorPruneDelay><SPDPInterval>{SPDP_INTERVAL}</SPDPInterval>"
    if where == "LOCALHOST":
        general = (
            "<Interfaces><NetworkInterface address='127.0.0.1'/></Interfaces><AllowMulticast>false</AllowMulticast>"
        )
        peers = ["127.0.0.1", *peers]
    elif where == "OFF":
        general = "<AllowMulticast>false</AllowMulticast>"
    if (peers and where != "SYSTEM_DEFAULT") or where in ("LOCALHOST", "OFF"):
        discovery += (
            f"<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>{MAX_PARTICIPANT_INDEX}"
            "</MaxAutoParticipantIndex>"
        )
    if peers:
        discovery += "<Peers>" + "".join(f"<Peer address={quoteattr(p)}/>" for p in peers) + "</Peers>"
    return (
        "<CycloneDDS><Domain Id='any'>"
        + (f"<General>{general}</General>" if general else "")
        + f"<Discovery>{discovery}</Discovery>"
        + "<Internal><GenerateKeyhash>true</GenerateKeyhash></Internal>"
        + "<Tracing><Verbosity>severe</Verbosity></Tracing>"
        + "</Domain></CycloneDDS>"
    )
