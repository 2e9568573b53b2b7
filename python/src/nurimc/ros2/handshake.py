"""A reliable reader in step at once with a writer that published before it matched it.

Cyclone DDS's reliable reader delivers a writer's samples in sequence. For a writer of another
vendor (Fast DDS: rclpy's default) it learns where its sequence starts only from that writer's
first HEARTBEAT; until then a sample numbered N > 1 waits for samples 1..N-1, which a volatile
writer never sends to a reader that matched after them. Fast DDS sends its HEARTBEAT once, when it
matches the reader, and the bridge's Cyclone heard of the writer (Fast DDS's discovery data comes
about a second later than ours reaches Fast DDS) only after that HEARTBEAT had arrived and been
dropped as from an unknown writer. The next HEARTBEAT came with Fast DDS's periodic one, 3 s later:
a node that had published before (to the previous bridge, or to nobody) saw its first command after
a bridge (re)start arrive 3 s late (docs/ros2.md, "Restarts and start-up", with the packet trace).

The remedy here: when a reader of ours matches a writer of another participant, a second reader
on that topic is announced for a moment (HOLD). The writer, matching it, sends it a HEARTBEAT, which
Cyclone now takes (it knows the writer), and which puts the writer's sequence in step for every
reader of ours; a sample already waiting is then delivered. One such reader per topic covers every
writer matched before it was announced.

At start-up, one more wait (`wait_until_heard`, before the first joint_states): Cyclone may learn a
Fast DDS node's readers about a second before its writers (Fast DDS sends the two kinds of discovery
data separately, each only when asked). In that window the node already gets joint_states, and a
command it sends at once is dropped (its writer unknown), then never asked for again (Cyclone counts
what the writer's first HEARTBEAT announces as history). So the bridge publishes its first
joint_states once it has heard the writers of every Fast DDS participant it knows of (at most
START_WAIT s).
"""

from __future__ import annotations

import contextlib
import queue
import threading
import time
from typing import Any

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication
from cyclonedds.core import InstanceState, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

HOLD = 2.0  # s a handshake reader stays: the writer's HEARTBEAT comes within milliseconds on a LAN
START_WAIT = 2.0  # s at most to wait at start for the writers of the Fast DDS participants known
FAST_DDS_PREFIX = b"\x01\x0f"  # eProsima's vendor id, which Fast DDS puts first in its GUIDs


class Handshakes:
    """Announces a short-lived reader on a topic after a writer matched one of our readers on it."""

    def __init__(self, participant: Any, hold: float = HOLD) -> None:
        self._participant = participant
        self._hold = hold
        self._requests: queue.Queue[tuple[Topic[Any], Qos, float] | None] = queue.Queue()
        self._announced: dict[str, float] = {}  # topic name -> when its latest handshake reader was announced
        self._expiring: list[tuple[float, DataReader[Any]]] = []  # readers to delete, by deadline
        self.count = 0  # handshake readers announced so far (for tests)
        self._participants = BuiltinDataReader(participant, BuiltinTopicDcpsParticipant)
        self._publications = BuiltinDataReader(participant, BuiltinTopicDcpsPublication)
        self._thread = threading.Thread(target=self._run, name="nurimc-dds-handshake", daemon=True)
        self._thread.start()

    def matched(self, topic: Topic[Any], qos: Qos, status: Any) -> None:
        """A reader's subscription-matched status (called on a DDS thread): a new writer asks for a handshake."""
        if status.current_count_change > 0:
            self._requests.put((topic, qos, time.monotonic()))

    def unheard(self) -> list[str]:
        """Fast DDS participants known whose writers we have not heard of yet (their GUIDs)."""
        alive, own = InstanceState.Alive, self._participant.guid.bytes
        participants = {
            p.key.bytes
            for p in self._participants.read(N=4096)
            if p.sample_info.instance_state == alive and p.key.bytes.startswith(FAST_DDS_PREFIX) and p.key.bytes != own
        }
        writers = self._publications.read(N=65536)
        heard = {w.participant_key.bytes for w in writers if w.sample_info.instance_state == alive}
        return sorted(key.hex() for key in participants - heard)

    def wait_until_heard(self, timeout: float = START_WAIT) -> bool:
        """Until every Fast DDS participant known has had its writers heard of (True), or `timeout`."""
        deadline = time.monotonic() + timeout
        while self.unheard():
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.02)
        return True

    def close(self) -> None:
        """Stop the thread; its readers go with the participant."""
        self._requests.put(None)
        self._thread.join(timeout=5)

    def _run(self) -> None:
        while True:
            timeout = max(0.0, self._expiring[0][0] - time.monotonic()) if self._expiring else None
            try:
                request = self._requests.get(timeout=timeout)
            except queue.Empty:
                request = ()  # type: ignore[assignment]
            if request is None:
                return
            now = time.monotonic()
            while self._expiring and self._expiring[0][0] <= now:
                self._delete(self._expiring.pop(0)[1])
            if request:
                topic, qos, asked = request
                try:
                    self._announce(topic, qos, asked)
                except Exception:  # a handshake is a help: its failure must not end the thread
                    pass
                finally:
                    self._requests.task_done()

    @property
    def idle(self) -> bool:
        """Every request so far handled (for tests)."""
        return self._requests.unfinished_tasks == 0

    def _announce(self, topic: Topic[Any], qos: Qos, asked: float) -> None:
        name = topic.get_name()
        if self._announced.get(name, -1.0) >= asked:
            return  # announced after that writer was known: its HEARTBEAT covers it
        now = time.monotonic()
        try:
            reader = DataReader(self._participant, topic, qos=qos)
        except Exception:  # the participant is closing
            return
        self._announced[name] = now
        self._expiring.append((now + self._hold, reader))
        self.count += 1

    @staticmethod
    def _delete(reader: DataReader[Any]) -> None:
        with contextlib.suppress(Exception):  # already gone with its participant
            reader.__del__()
