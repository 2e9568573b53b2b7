"""Where our RTPS participant listens and whom it asks: the same answer the bridge's Cyclone DDS gets.

Read from the same sources, in the same order (ros2/ddsconfig.py): ROS_AUTOMATIC_DISCOVERY_RANGE and
ROS_STATIC_PEERS, then the user's CYCLONEDDS_URI (its NetworkInterface, AllowMulticast and Peers
override). So the tests' loopback pinning and a user's interface choice hold for both participants,
and our sockets are bound to the chosen interface's address, never 0.0.0.0 when one is chosen.
"""

from __future__ import annotations

import os
import re
import socket
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

from ..ddsconfig import MAX_PARTICIPANT_INDEX, discovery_range, static_peers

PORT_BASE, DOMAIN_GAIN, PARTICIPANT_GAIN = 7400, 250, 2
OFFSET_META_MULTICAST, OFFSET_USER_MULTICAST, OFFSET_META_UNICAST, OFFSET_USER_UNICAST = 0, 1, 10, 11
MULTICAST_GROUP = "239.255.0.1"
SIOCGIFADDR = 0x8915


@dataclass
class NetConfig:
    domain: int = 0
    #: the interface address our sockets bind to and announce; None: every IPv4 interface (0.0.0.0)
    address: str | None = None
    multicast: bool = True
    peers: list[str] = field(default_factory=list)
    max_index: int = MAX_PARTICIPANT_INDEX

    def meta_unicast_port(self, index: int) -> int:
        return PORT_BASE + DOMAIN_GAIN * self.domain + OFFSET_META_UNICAST + PARTICIPANT_GAIN * index

    def user_unicast_port(self, index: int) -> int:
        return PORT_BASE + DOMAIN_GAIN * self.domain + OFFSET_USER_UNICAST + PARTICIPANT_GAIN * index

    @property
    def meta_multicast_port(self) -> int:
        return PORT_BASE + DOMAIN_GAIN * self.domain + OFFSET_META_MULTICAST


def interface_address(name: str) -> str | None:
    """The IPv4 address of a network interface by name (Linux), or None."""
    try:
        import fcntl  # POSIX only
    except ImportError:
        return None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            raw = fcntl.ioctl(s.fileno(), SIOCGIFADDR, struct.pack("256s", name.encode()[:15]))
        except OSError:
            return None
    return socket.inet_ntoa(raw[20:24])


def routed_address() -> str | None:
    """The address this host sends multicast from (no packet is sent), where interfaces cannot be listed."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.connect((MULTICAST_GROUP, 7400))
            address: str = s.getsockname()[0]
        except OSError:
            return None
    return None if address.startswith(("127.", "0.")) else address


def local_addresses() -> list[str]:
    """Every IPv4 address of this host's interfaces but loopback (announced to other machines, a
    127.0.0.1 locator would point them at themselves); loopback only when there is nothing else."""
    found = []
    try:
        names = [name for _, name in socket.if_nameindex()]
    except OSError:
        names = []
    for name in names:
        address = interface_address(name)
        if address and address not in found and not address.startswith("127."):
            found.append(address)
    if not found:
        routed = routed_address()
        found = [routed] if routed else []
    return found or ["127.0.0.1"]


def _user_xml(text: str) -> str:
    """CYCLONEDDS_URI's fragments (XML, file paths or file:// URIs, comma-separated) as one text."""
    parts = []
    for item in re.split(r",(?=\s*(?:<|file://|/|\w:))", text):
        item = item.strip()
        if not item:
            continue
        if item.startswith("<"):
            parts.append(item)
        else:
            path = item[len("file://") :] if item.startswith("file://") else item
            try:
                parts.append(Path(os.path.expandvars(path)).read_text())
            except OSError:
                continue  # Cyclone itself reports a file it cannot read
    return "\n".join(parts)


def _bool(text: str) -> bool:
    return text.strip().lower() in ("true", "1", "yes", "default", "spdp", "asm", "ssm", "any")


def from_environment(domain: int, environ: Mapping[str, str] | None = None) -> NetConfig:
    env = os.environ if environ is None else environ
    config = NetConfig(domain=domain)
    where = discovery_range(env)
    peers = static_peers(env)
    if where == "LOCALHOST":
        config.address, config.multicast = "127.0.0.1", False
        peers = ["127.0.0.1", *peers]
    elif where == "OFF":
        config.multicast = False
    user = _user_xml(env.get("CYCLONEDDS_URI", ""))
    for fragment in re.findall(r"<CycloneDDS\b.*?(?:</CycloneDDS>|$)", user, re.S) if user else []:
        try:
            ElementTree.fromstring(fragment)
        except ElementTree.ParseError as error:
            raise ValueError(
                f"CYCLONEDDS_URI is not well-formed XML ({error}): fix it, or unset it to use the defaults"
            ) from None
    if user:
        match = re.search(r"<NetworkInterface\b([^>]*)>", user)
        if match:
            attrs = dict(re.findall(r"(\w+)\s*=\s*['\"]([^'\"]*)['\"]", match.group(1)))
            if "address" in attrs:
                config.address = attrs["address"]
            elif "name" in attrs:
                config.address = interface_address(attrs["name"]) or config.address
        match = re.search(r"<NetworkInterfaceAddress>\s*([^<\s]+)\s*<", user)
        if match:
            named = match.group(1)
            config.address = named if re.match(r"^\d+\.\d+\.\d+\.\d+$", named) else interface_address(named)
        match = re.search(r"<AllowMulticast>([^<]*)<", user)
        if match:
            config.multicast = _bool(match.group(1))
        user_peers = re.findall(r"<Peer\s+address\s*=\s*['\"]([^'\"]+)['\"]", user)
        if user_peers:
            peers = [*user_peers, *[p for p in peers if p not in user_peers]]
        match = re.search(r"<MaxAutoParticipantIndex>\s*(\d+)\s*<", user)
        if match:
            config.max_index = int(match.group(1))
    resolved = []
    for peer in dict.fromkeys(peers):
        host = peer.split(":")[0] if peer.count(":") == 1 else peer
        try:
            resolved.append(socket.gethostbyname(host))
        except OSError:
            continue  # a name that does not resolve (yet): Cyclone keeps asking; we skip it
    config.peers = list(dict.fromkeys(resolved))
    return config
