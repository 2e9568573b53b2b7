"""The bridge on a bus and a DDS participant: one thread owns the bus, DDS callbacks only queue.

DDS delivers commands on Cyclone's own threads; they are queued here and the bus thread
carries them out between readings, so a command waits at most for the reading under way.
An estop drops every command queued before it and goes first. Commands coalesce (coalesce.py):
the latest motion command replaces one still queued, so a flood costs no backlog; a reading or
/diagnostics that is due goes before queued commands (never before an estop), so a flood does not
starve joint_states either.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

from ..drivers.sync import Bus
from ..errors import NurimcError, PortLost
from ..procedures.group import read_states, read_states_broadcast, stagger
from ..procedures.motor import Motor, MotorState
from ..procedures.stop import StopResult, emergency_stop
from ..protocol import FieldRangeError
from ..protocol.host import STOP_VERIFY
from ..service.backoff import Backoff, read_state_once
from ..transport.outage import OutageGuard
from . import msgs
from .bridge import Action, Bridge, Hold, MoveTo, Refused, ReleaseAll, Run
from .coalesce import CommandQueue
from .dds import Participant
from .graph import NodeAnnouncer
from .names import topic
from .qoswatch import IncompatibleWriters

DIAGNOSTICS_PERIOD = 1.0  # s: /diagnostics at 1 Hz
DISCOVERY_WAIT = 0.5  # s to listen for another bridge on our topics before starting
FIRST_READING_RETRY = 1.0  # s between two tries of the first reading when no motor answers
LOG_REPEAT = 2.0  # s between two reports of the same kind of trouble on stderr


class NamespaceTaken(NurimcError):
    """Another participant already publishes our joint_states: two bridges would collide."""


class StateSink(Protocol):
    """Also given each JointState published (e.g. an MCAP recorder)."""

    def joint_state(self, topic: str, message: msgs.JointState) -> None: ...


class BridgeNode:
    def __init__(
        self,
        bus: Bus,
        bridge: Bridge,
        participant: Participant,
        namespace: str = "/",
        rate: float = 50.0,
        product: str = "mc",
        broadcast_read: bool = False,
        sink: StateSink | None = None,
        log: Callable[[str], None] | None = None,
        node_name: str | None = "nurimc",
    ) -> None:
        if rate < 0 or not math.isfinite(rate):
            raise ValueError(f"--rate {rate}: give readings per second > 0 (0 = as fast as the bus allows)")
        self.bus = bus
        self.bridge = bridge
        self.participant = participant
        self.namespace = namespace
        self.period = 1.0 / rate if rate else 0.0
        # the product line discovery found for an ID (nurimc.procedures.products) beats the default "mc"
        self.motors = {
            i: Motor(bus, i, (bus.core.products.get(i) if product == "mc" else None) or product) for i in bridge.ids
        }
        self.broadcast_read = broadcast_read
        self.slot: int | None = None
        self.sink = sink
        self._log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self._logged: dict[str, float] = {}
        self.outage = OutageGuard(bus.transport, self._log)  # port lost and back (docs/ros2.md, "Port lost")
        self.joint_states_topic = topic(namespace, "joint_states")
        self.prefix = f"nurimc{'' if namespace == '/' else namespace}"
        self.hardware = f"{bus.transport.url} @ {bus.baudrate} bps"
        self.published = 0
        self._events = CommandQueue()
        self._wake = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self.done = threading.Event()
        self.failure: str | None = None
        #: a command publisher with an incompatible QoS (best effort) is logged once, by node name
        self.qos_watch = IncompatibleWriters(participant.participant, self._log)
        participant.on_incompatible_qos = self.qos_watch.on_incompatible
        self._state_writer = participant.writer(self.joint_states_topic, msgs.JointState)
        self._diagnostics_writer = participant.writer("/diagnostics", msgs.DiagnosticArray)
        self._readers = [
            participant.reader(topic(namespace, "position_commands"), msgs.Float64MultiArray, self._queue("position")),
            participant.reader(topic(namespace, "velocity_commands"), msgs.Float64MultiArray, self._queue("velocity")),
            participant.reader(topic(namespace, "estop"), msgs.Bool, self._queue("estop")),
        ]
        #: also given every other message published (diagnostics, odom, /tf): an MCAP recorder's write()
        self.recorder: Callable[[str, Any], None] | None = None
        #: called on the bus thread after each reading is published (ros2_control topics, mobile base)
        self.after_read: list[Callable[[float], list[Action]]] = []
        self.silent = Backoff()  # motors that stopped answering (docs/service.md)
        self.on_stop: list[Callable[[StopResult], None]] = []  # given the result of each estop
        #: given each round of readings (ID -> state or error): the bus service shares them with attached programs
        self.on_states: list[Callable[[dict[int, MotorState | Exception]], None]] = []
        #: the node in the ROS 2 graph (announced at start, when every endpoint exists)
        self.graph = NodeAnnouncer(participant, node_name, namespace) if node_name else None

    # -- DDS threads ------------------------------------------------------------------------
    def _queue(self, kind: str) -> Callable[[Any], None]:
        def on_data(reader: Any) -> None:
            for sample in reader.take(N=64):
                if isinstance(sample, msgs.Bool):
                    self._push("estop", sample.data)
                elif isinstance(sample, msgs.Float64MultiArray):
                    self._push(kind, list(sample.data))

        return on_data

    def call_on_bus_thread(self, work: Callable[[float], list[Action]], key: str | None = None) -> None:
        """Queue work (from a DDS thread) that returns the actions to carry out; an estop drops it.
        Work with a key replaces queued work of the same key (latest wins: coalesce.py)."""
        self._push("call", work, key)

    def _push(self, kind: str, value: Any, key: str | None = None) -> None:
        with self._wake:
            # A stop wins over everything queued before it; the latest motion command wins (coalesce.py).
            self._events.push(kind, value, key)
            self._wake.notify()

    # -- life --------------------------------------------------------------------------------
    def prepare(
        self,
        discovery_wait: float = DISCOVERY_WAIT,
        stop: threading.Event | None = None,
        retry: float = FIRST_READING_RETRY,
    ) -> dict[int, MotorState | Exception]:
        """Refuse a namespace another bridge already serves; stagger for broadcast reads if asked; a first
        reading. With `stop`, a first reading that no motor answers is retried every `retry` seconds
        (a line on stderr each time, at most every LOG_REPEAT s) until one answers or `stop` is set
        (then the error is raised); without it the error is raised at once."""
        if discovery_wait and self.participant.other_writers(self.joint_states_topic, msgs.JointState, discovery_wait):
            raise NamespaceTaken(
                f"another program already publishes {self.joint_states_topic} on DDS domain "
                f"{self.participant.domain}: give each bus its own --namespace"
            )
        procedures = [m.procedures for m in self.motors.values()]
        if self.broadcast_read:
            self.slot = self.bus.run(stagger(procedures, self.bus.baudrate))
        attempt = 1
        while True:
            try:
                results = self.bus.run(read_states(procedures))
            except NurimcError as port_error:  # the port itself: every motor gets the error
                results = {device_id: port_error for device_id in self.motors}
            if not all(isinstance(r, Exception) for r in results.values()):
                break
            first = next(iter(results.values()))
            failure = first if isinstance(first, NurimcError) else NurimcError(str(first))
            if stop is None or stop.is_set():
                raise failure
            self._report(
                "first",
                f"first reading failed (attempt {attempt}): {failure}; retrying every {retry:g} s until a motor "
                "answers (Ctrl-C to stop)",
            )
            attempt += 1
            if stop.wait(retry):
                raise failure
        if attempt > 1:
            self._log(f"first reading succeeded on attempt {attempt}")
        for device_id, result in results.items():
            if isinstance(result, Exception):
                self._log(f"warning: ID {device_id}: {result}")
        self.bridge.readings(results)
        return results

    def start(self) -> None:
        if self.graph is not None:
            self.graph.announce()
        self._thread = threading.Thread(target=self.run, name="nurimc-ros2-bridge", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        with self._wake:
            self._stopping = True
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout=10)

    def close(self) -> None:
        self.stop()
        self.participant.close()

    # -- the bus thread ----------------------------------------------------------------------
    def run(self) -> None:
        """The bus loop, until stop(); `done` is set when it ends, `failure` says why if it broke."""
        try:
            self._loop()
        except Exception as error:  # a bug must not leave motors turning unattended: stop what turns
            self.failure = f"internal error in the bridge: {type(error).__name__}: {error}"
            self._log(self.failure)
            self._carry_out(self.bridge.shutdown())
        finally:
            self.done.set()

    def _loop(self) -> None:
        next_read = time.monotonic()
        next_diagnostics = next_read
        just_read = False
        while True:
            with self._wake:
                if self._stopping:
                    break
                now = time.monotonic()
                wake_at = min(next_read, next_diagnostics, self.bridge.next_expiry() or math.inf)
                # an estop first; then a reading, diagnostics or timeout that is due; then commands
                # (--rate 0 reads all the time: a reading and a command take turns)
                first = self._events.has_estop() or wake_at > now or (not self.period and just_read)
                event = self._events.pop() if first else None
                just_read = False
                if event is None and wake_at > now:
                    self._wake.wait(wake_at - now)
                    continue
            now = time.monotonic()
            if self.outage.returned():  # before anything else: stops owed, fresh states
                self._resume()
            if event is not None:
                self._handle(*event, now)
                continue
            self._carry_out(self.bridge.expire(now))
            if now >= next_read:
                self.read_and_publish()
                just_read = True
                next_read = max(next_read + self.period, time.monotonic()) if self.period else time.monotonic()
                if self.outage.down:  # no reading can succeed: look again later, not in a busy loop
                    next_read = max(next_read, time.monotonic() + self.outage.recheck)
            if now >= next_diagnostics:
                self.publish_diagnostics()
                next_diagnostics = now + DIAGNOSTICS_PERIOD
        self._carry_out(self.bridge.shutdown())
        self.outage.ending()
        if self.outage.not_stopped and self.outage.down:
            ids = ", ".join(map(str, sorted(self.outage.not_stopped)))
            self.failure = f"the port is lost: ID {ids} could not be stopped and may still be turning"

    def _resume(self) -> None:
        """The port is back: control off already went first to each motor whose stop was owed
        (it stays released: holding would turn control on, an EEPROM write that keeps the
        controller deaf for up to 300 ms). What was known of control before is forgotten, so the
        next motion reads it first; every motor is read before anything else is sent."""
        self.outage.take_stops()
        self.bus.core.control_released.clear()
        self.read_and_publish()

    def _handle(self, kind: str, value: Any, now: float) -> None:
        try:
            if kind == "estop":
                actions = self.bridge.estop(bool(value), now)
            elif kind == "position":
                actions = self.bridge.position_command(value, now)
            elif kind == "call":
                actions = value(now)
            else:
                actions = self.bridge.velocity_command(value, now)
        except Refused as error:
            self._report("refused", f"refused: {error}")
            return
        self._carry_out(actions)

    def _carry_out(self, actions: list[Action]) -> None:
        for action in actions:
            try:
                self._perform(action)
            except PortLost as error:  # dropped, never replayed; a stop is owed on the return
                if isinstance(action, Hold | ReleaseAll):
                    ids = action.ids if isinstance(action, ReleaseAll) else (action.id,)
                    self.outage.stop_failed(ids, error, ending=self._stopping)
                else:
                    self._report("port", f"dropped while the port is lost (not replayed): {action}")
            except (NurimcError, FieldRangeError, ValueError) as error:
                self._report(f"action{getattr(action, 'id', '')}", f"error: {action}: {error}")

    def _perform(self, action: Action) -> None:
        if isinstance(action, MoveTo):
            self.motors[action.id].move_to(action.degrees, rpm=action.rpm)
        elif isinstance(action, Run):
            self.motors[action.id].run(action.rpm, action.ramp)
        elif isinstance(action, Hold):
            self.motors[action.id].hold()
        elif isinstance(action, ReleaseAll):
            self.release_all(action.ids)

    def release_all(self, ids: tuple[int, ...]) -> StopResult:
        """The one emergency stop (nurimc.procedures.stop, docs/service.md): control off by broadcast,
        then to each motor by ID, read back until each says off or spec/host.json's window runs out."""
        motors = {i: (self.motors[i].procedures, self.bus.baudrate) for i in ids}
        result = self.bus.run(emergency_stop(self.bus.core, motors))
        if result.not_confirmed:
            ids_text = ", ".join(map(str, result.not_confirmed))
            self._log(f"estop: ID {ids_text} did not confirm control off within {STOP_VERIFY} s")
        if result.stopped:
            self._log(f"estop: control off confirmed on ID {', '.join(map(str, result.stopped))}")
        for told in self.on_stop:  # the programs attached to this port are told (docs/service.md)
            told(result)
        return result

    def read_states(self) -> dict[int, MotorState | Exception]:
        procedures = [m.procedures for m in self.motors.values()]
        if self.slot is not None:
            try:
                return dict(self.bus.run(read_states_broadcast(procedures, self.slot)))
            except NurimcError as error:
                return {m.id: error for m in procedures}
        # a motor that stopped answering is read less often (service/backoff.py): the others keep their rate
        now = self.bus.clock.now()
        due = [p for p in procedures if self.silent.due(p.id, now) and not self.silent.silent(p.id)]
        results: dict[int, MotorState | Exception] = dict(self.bus.run(read_states(due))) if due else {}
        for p in procedures:  # a silent motor whose wait is over: one attempt, no retries
            if self.silent.silent(p.id) and self.silent.due(p.id, now):
                try:
                    results[p.id] = self.bus.run(read_state_once(p))
                except NurimcError as error:
                    results[p.id] = error
        now = self.bus.clock.now()
        for device_id, result in list(results.items()):
            if isinstance(result, Exception):
                if self.silent.failed(device_id, now):
                    self._log(f"ID {device_id}: no answer; read less often (at most 1 s apart) until it answers")
            elif self.silent.answered(device_id) is not None:
                self._log(f"ID {device_id} answers again")
        for p in procedures:
            if p.id not in results:
                results[p.id] = NurimcError(f"ID {p.id} is not answering; read again in a moment")
        return results

    def read_and_publish(self) -> msgs.JointState | None:
        try:
            results = self.read_states()
        except NurimcError as error:  # the port itself (adapter unplugged...): every motor gets the error
            results = {device_id: error for device_id in self.motors}
        self.bridge.readings(results)
        for joint in self.bridge.joints:
            if joint.error and not self.outage.down:  # a lost port is said once, by the outage guard
                self._report(f"read{joint.id}", f"ID {joint.id}: {joint.error}")
        message = self.bridge.joint_state(time.time_ns())
        if message is not None:
            self._state_writer.write(message)
            self.published += 1
            if self.sink is not None:
                self.sink.joint_state(self.joint_states_topic, message)
        for work in self.after_read:
            self._carry_out(work(time.monotonic()))
        for offer in self.on_states:  # shared with the programs attached to this port (docs/service.md)
            offer(results)
        return message

    def publish_diagnostics(self) -> None:
        stats = self.bus.stats.as_dict()
        stats |= {
            "baudrate": self.bus.baudrate,
            "port": self.bus.transport.url,
            "joint_states_published": self.published,
            "coalesced_commands": self._events.dropped,  # replaced by a later one before reaching the bus
        }
        array = self.bridge.diagnostics(time.time_ns(), self.prefix, self.hardware, stats)
        self._diagnostics_writer.write(array)
        self.record("/diagnostics", array)

    def record(self, topic: str, message: Any) -> None:
        """Hand a published message to the recorder, if there is one (--mcap)."""
        if self.recorder is not None:
            self.recorder(topic, message)

    def _report(self, kind: str, text: str) -> None:
        """stderr, but the same kind of trouble at most every LOG_REPEAT seconds."""
        now = time.monotonic()
        if now - self._logged.get(kind, -math.inf) >= LOG_REPEAT:
            self._logged[kind] = now
            self._log(text)
