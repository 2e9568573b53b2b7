"""Every DDS test here stays on the loopback interface: no multicast, the only peer 127.0.0.1.

Set before any participant exists (Cyclone DDS reads CYCLONEDDS_URI when a domain is created),
and inherited by the bridge processes the tests start. A domain ID of its own per test run keeps
two runs on one machine apart.
"""

from __future__ import annotations

import os
import random

LOOPBACK_ONLY = (
    "<CycloneDDS><Domain Id='any'>"
    "<General><Interfaces><NetworkInterface name='lo'/></Interfaces>"
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery>"
    "</Domain></CycloneDDS>"
)

os.environ["CYCLONEDDS_URI"] = LOOPBACK_ONLY
os.environ["ROS_DOMAIN_ID"] = str(random.SystemRandom().randrange(100, 200))
