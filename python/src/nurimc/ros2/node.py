"""The bridge on a bus service and a DDS participant: the service owns the bus, DDS callbacks only queue.

The bridge is a client of one BusService (service/core.py, docs/service.md): its readings are a
subscription of the service's poll schedule at --rate (0: as fast as the bus allows), its
commands are jobs of COMMAND priority, its estop is the service's one emergency stop. DDS delivers
commands on Cyclone's own threads; they are queued here and the node's thread hands them to the
service one at a time, so the service reads between two commands and a command waits at most for
the reading under way. An estop drops every command queued before it and goes first. Commands
coalesce (coalesce.py): the latest motion command replaces one still queued (latest wins per joint)
before it is submitted, so a flood costs no backlog; a round of readings or /diagnostics that is
due is published before queued commands (never before an estop), so a flood does not starve
joint_states either. With --broadcast-read the node asks for its broadcast reads itself, as READ
jobs of the service, at --rate.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

from ..drivers.sync import Bus
from ..errors import NurimcError, PortLost
from ..procedures.group import read_states, read_states_broadcast, read_states_now, stagger
from ..procedures.motor import Motor, MotorState
from ..procedures.stop import StopResult
from ..protocol import FieldRangeError
from ..protocol.host import STOP_VERIFY
from ..service.backoff import Backoff, read_state_once
from ..service.core import COMMAND, READ, BusService, Sample, Subscription
from ..service.readings import AS_FAST
from ..transport.outage import OutageGuard
from . import msgs
from .bridge import Action, Bridge, Hold, MoveTo, Refused, ReleaseAll, Run
from .coalesce import CommandQueue
from .dds import Participant
from .names import topic

if TYPE_CHECKING:
    from .rtps.topics import RtpsParticipant

DIAGNOSTICS_PERIOD = 1.0  # s: /diagnostics at 1 Hz
DISCOVERY_WAIT = 0.5  # s to listen for another bridge on our topics before starting
FIRST_READING_RETRY = 1.0  # s between two tries of the first reading when no motor answers
LOG_REPEAT = 2.0  # s between two reports of the same kind of trouble on stderr

T = TypeVar("T")


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
        participant: Participant | RtpsParticipant,
        namespace: str = "/",
        rate: float = 50.0,
        product: str = "mc",
        broadcast_read: bool = False,
        sink: StateSink | None = None,
        log: Callable[[str], None] | None = None,
        node_name: str | None = "nurimc",
        service: BusService | None = None,
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
        #: the bus service the bridge is a client of (its own unless given: a holder's, a test's clock)
        self.own_service = service is None
        self.service = service or BusService(bus, say=self._log, product=product, program="nurimc ros2", say_port=False)
        for motor in self.motors.values():  # one handle per ID: the multi-turn tracker's history is the bridge's
            self.service.adopt(motor)
        self.service.listen(self._service_event)
        self.rate = rate
        self.subscription: Subscription | None = None
        self._round: dict[int, MotorState | Exception] = {}  # readings of this round so far (from the service)
        self._round_since: float | None = None  # monotonic time of the round's first reading
        self._round_full = False  # every motor but the silent ones is in the round: publish now
        self._silent: set[int] = set()  # motors the service reads less often (not waited for)
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
        self.qos_watch = participant.qos_watch(self._log)
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
        #: the mobile base (diffdrive.attach), if any: its limits are parameters (parameters.py)
        self.base: Any = None
        #: the node in the ROS 2 graph (announced at start, when every endpoint exists)
        self.graph = participant.node_announcer(node_name, namespace) if node_name else None

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

    def run_on_bus_thread(self, change: Callable[[], T], timeout: float) -> T:
        """Carry out `change` on the node's thread (between two commands) and return its result; at
        once when that thread is not running. TimeoutError when it was not done within `timeout`
        (an estop dropped it, or the thread is stuck): services.py answers with that."""
        if self._thread is None or not self._thread.is_alive() or self._thread is threading.current_thread():
            return change()
        future: Future[T] = Future()

        def work(_now: float) -> list[Action]:
            try:
                future.set_result(change())
            except Exception as error:  # handed to the caller (a service's transport thread)
                future.set_exception(error)
            return []

        self.call_on_bus_thread(work)
        return future.result(timeout)

    def set_rate(self, rate: float) -> None:
        """A new --rate at run time (the `rate` parameter): the service's poll is subscribed again
        at the new rate (with --broadcast-read the node's own reads follow the new period)."""
        if rate < 0 or not math.isfinite(rate):
            raise ValueError(f"rate {rate}: give readings per second >= 0 (0 = as fast as the bus allows)")
        self.rate = rate
        self.period = 1.0 / rate if rate else 0.0
        if self.subscription is not None:
            self.subscription.cancel()
            self.subscription = None
            self.subscribe()

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
            self.slot = self.service.run(stagger(procedures, self.bus.baudrate), priority=COMMAND)
        attempt = 1
        while True:
            try:
                results = self.service.run(read_states(procedures), priority=READ)
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
        # no joint_states (which a node may answer with a command at once) before its writers are known
        self.participant.wait_for_writers()
        self.subscribe()
        self.service.start()
        self._thread = threading.Thread(target=self.run, name="nurimc-ros2-bridge", daemon=True)
        self._thread.start()

    def subscribe(self) -> None:
        """The readings: a subscription of the service's poll schedule at --rate (not with
        --broadcast-read: the node asks for those itself). `start()` does it; a test on virtual
        time calls it and steps the service itself."""
        if self.slot is None and self.subscription is None:
            rate = self.rate if self.rate else AS_FAST
            self.subscription = self.service.subscribe(list(self.motors), rate, self._sample, client=self.service.me)

    def stop(self) -> None:
        with self._wake:
            self._stopping = True
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout=10)
        if self.subscription is not None:
            self.subscription.cancel()
            self.subscription = None
        if self.own_service:
            self.service.close()

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

    # -- the service's thread: readings and events ------------------------------------------
    def _sample(self, sample: Sample) -> None:
        """A reading from the service's polls: part of the round the node publishes next."""
        value: MotorState | Exception = (
            sample.state if sample.state is not None else NurimcError(sample.error or f"ID {sample.id} did not answer")
        )
        with self._wake:
            first = self._round_since is None
            if first:
                self._round_since = time.monotonic()
            self._round[sample.id] = value
            if self._round.keys() >= self.motors.keys() - self._silent:
                self._round_full = True
            # the first reading of a round sets when it is published (a period later if a motor is
            # missing: a read under way), so the node's thread must look at the clock again
            if first or self._round_full:
                self._wake.notify()

    def _service_event(self, event: dict[str, Any]) -> None:
        """A motor that stops answering is read less often by the service (service/backoff.py): said once each way."""
        kind = event.get("type")
        if kind == "no_answer" and event.get("id") in self.motors:
            with self._wake:  # a round no longer waits for it (its rare error readings join any round)
                self._silent.add(event["id"])
            self._log(f"ID {event['id']}: no answer; read less often (at most 1 s apart) until it answers")
        elif kind == "answering" and event.get("id") in self.motors:
            with self._wake:
                self._silent.discard(event["id"])
            self._log(f"ID {event['id']} answers again")

    def _round_due(self, now: float) -> float:
        """When the round of readings gathered so far is published: at once when every motor is in
        it, else (a motor backed off, a read under way) a period after its first reading."""
        if self._round_since is None:
            return math.inf
        if self._round_full:
            return now
        return self._round_since + max(self.period, 0.02)

    def _take_round(self) -> dict[int, MotorState | Exception]:
        with self._wake:
            results, self._round, self._round_since, self._round_full = self._round, {}, None, False
        for device_id in self.motors:
            if device_id not in results:
                results[device_id] = NurimcError(f"ID {device_id} is not answering; read again in a moment")
        return results

    # -- the node's thread ----------------------------------------------------------------------
    def _loop(self) -> None:
        next_read = time.monotonic()  # broadcast reads only: the node asks for them itself
        next_diagnostics = next_read
        just_read = False
        while True:
            with self._wake:
                if self._stopping:
                    break
                now = time.monotonic()
                round_at = self._round_due(now)
                wake_at = min(
                    next_read if self.slot is not None else math.inf,
                    round_at,
                    next_diagnostics,
                    self.bridge.next_expiry() or math.inf,
                )
                # an estop first; then a round of readings, diagnostics or a timeout that is due; then
                # commands (--rate 0 reads all the time: a round and a command take turns)
                first = self._events.has_estop() or wake_at > now or (not self.period and just_read)
                event = self._events.pop() if first else None
                just_read = False
                if event is None and wake_at > now:
                    self._wake.wait(wake_at - now)
                    continue
            now = time.monotonic()
            if self.outage.returned():  # before anything else: stops owed (the service reads every motor first)
                self._resume()
            if event is not None:
                self._handle(*event, now)
                continue
            self._carry_out(self.bridge.expire(now))
            if round_at <= now:
                self.publish(self._take_round())
                just_read = True
            if self.slot is not None and now >= next_read:
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
        if self.slot is not None:  # else the service reads every subscribed motor first on the return
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
        """A command is a job of the service (COMMAND priority; it clears that motor's stop latch)."""
        if isinstance(action, ReleaseAll):
            self.release_all(action.ids)
            return
        motor = self.motors[action.id]
        if isinstance(action, MoveTo):
            self.service.run(lambda _bus: motor.move_to(action.degrees, rpm=action.rpm), COMMAND, [action.id])
        elif isinstance(action, Run):
            self.service.run(lambda _bus: motor.run(action.rpm, action.ramp), COMMAND, [action.id])
        elif isinstance(action, Hold):
            self.service.run(lambda _bus: motor.hold(), COMMAND, [action.id])

    def release_all(self, ids: tuple[int, ...]) -> StopResult:
        """The service's one emergency stop (nurimc.procedures.stop, docs/service.md): control off by
        broadcast, then to each motor it knows (the bridge's `ids` among them) by ID, read back until
        each says off or spec/host.json's window runs out; every program on the service is told."""
        self.service.add_motors({i: self.service.known.get(i, self.bus.baudrate) for i in ids})
        result = self.service.emergency_stop()
        if self.service.stop_pending:  # the port is lost: control off goes first on its return
            raise PortLost("the port is lost; the stop is sent first when it returns")
        if result.not_confirmed:
            ids_text = ", ".join(map(str, result.not_confirmed))
            self._log(f"estop: ID {ids_text} did not confirm control off within {STOP_VERIFY} s")
        if result.stopped:
            self._log(f"estop: control off confirmed on ID {', '.join(map(str, result.stopped))}")
        for told in list(self.on_stop):  # the programs attached to this port are told (docs/service.md)
            told(result)
        return result

    def read_states(self) -> dict[int, MotorState | Exception]:
        """One round read by the node itself (--broadcast-read: as a READ job of the service)."""
        procedures = [m.procedures for m in self.motors.values()]
        if self.slot is not None:
            try:
                return dict(self.service.run(read_states_broadcast(procedures, self.slot), priority=READ))
            except NurimcError as error:
                return {m.id: error for m in procedures}
        # a motor that stopped answering is read less often (service/backoff.py): the others keep their rate
        now = self.bus.clock.now()
        due = [p for p in procedures if self.silent.due(p.id, now) and not self.silent.silent(p.id)]
        results: dict[int, MotorState | Exception] = read_states_now(self.bus, due) if due else {}  # the fast path
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
        return self.publish(results)

    def publish(self, results: dict[int, MotorState | Exception]) -> msgs.JointState | None:
        """A round of readings: joint_states, then the hooks (ros2_control topics, the base)."""
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
