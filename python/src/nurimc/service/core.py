"""The bus service: one object owns one bus, and every program's work goes through it
(docs/service.md).

- One queue of jobs with priorities: the emergency stop first, then commands, then reads. An
  emergency stop drops every job queued before it (each fails with `Cancelled`).
- One poll schedule shared by every subscriber: each motor is read once per due time, at the
  highest rate any subscriber asked for, and the reading is handed to every subscriber of that
  motor (a subscriber asking less often gets every n-th). A motor that stops answering is read
  less often (backoff, one attempt each time, up to BACKOFF_MAX) and reported ("no answer
  since T"); the other motors keep their rate; it is picked up again when it answers.
- One emergency stop (procedures/stop.py): control off at every rate a motor was seen at, read
  back within the window of spec/host.json; polling goes on during and after it (multi-turn
  tracking keeps counting turns while the motors coast); the stop is latched for every motor
  until some program commands that motor again.
- The outage guard (outage.py): with a reconnecting port, polling pauses while it is down, a
  stop asked meanwhile is latched and sent first on the return, and every known motor is read
  again before anything else.

Time comes only from the clock (core/clock.py). Without a thread (`start()` not called) the
caller drives: `step()` does one unit of work, `run_for(s)` / `run_until(t)` let time pass
doing what is due, and `run(...)` steps until its job is done; tests run it on a VirtualClock
with the in-process simulator. With `start()`, one worker thread does the same.
"""

from __future__ import annotations

import heapq
import inspect
import itertools
import os
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import Future
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar, cast

from ..core.actions import Procedure
from ..core.clock import Clock
from ..drivers.sync import Bus
from ..errors import NurimcError, PortLost
from ..procedures.discovery import Found, discover
from ..procedures.motor import Motor, MotorProcedures, MotorState
from ..procedures.stop import Idle, StopResult, emergency_stop
from ..protocol import BROADCAST_ID, SetControl
from ..protocol.host import STOP_VERIFY
from ..transport.outage import OutageGuard
from ..transport.reconnect import reconnecting
from .backoff import read_state_once

T = TypeVar("T")

ESTOP, COMMAND, READ = 0, 1, 2
PRIORITY_NAMES = {"estop": ESTOP, "command": COMMAND, "read": READ}

SILENT_AFTER = 2  # failed reads in a row before a motor is "not answering" (one lost frame is not)
BACKOFF_FIRST = 0.1  # s before the first retry of a motor that does not answer
BACKOFF_MAX = 1.0  # s: the longest a silent motor goes unread
OUTAGE_RECHECK = 0.1  # s between two looks at a lost port
MAX_QUEUED = 256  # jobs waiting at most; more are refused (QueueFull), never stored


class Cancelled(NurimcError):
    """The job was queued before an emergency stop (the stop wins over everything queued before it)."""


class QueueFull(NurimcError):
    """Too many jobs waiting: this one was refused."""


class ServiceClosed(NurimcError):
    """The service has ended (its holder stopped)."""


class Interrupted(NurimcError):
    """An emergency stop cut a long job short (at its next progress note)."""


@dataclass(frozen=True, slots=True)
class Sample:
    """One reading of one motor, handed to every subscriber of it. `state` None: the read failed
    (`error` says why); `silent_since`: the motor has not answered since then (clock time)."""

    id: int
    t: float
    state: MotorState | None
    error: str | None = None
    silent_since: float | None = None


@dataclass
class ClientInfo:
    """A program using the service (the holder itself, or an attached one)."""

    program: str
    pid: int
    since: float  # wall-clock time (time.time) it came
    requests: int = 0
    polls: int = 0
    key: int = 0

    def as_dict(self) -> dict[str, Any]:
        return {
            "program": self.program,
            "pid": self.pid,
            "since": self.since,
            "requests": self.requests,
            "polls": self.polls,
        }


class Subscription:
    """Readings of some motors at a rate, handed to `callback(sample)` (from the service's thread)."""

    def __init__(
        self,
        service: BusService,
        motors: tuple[int, ...],
        rate_hz: float,
        callback: Callable[[Sample], None],
        signals: tuple[str, ...],
        client: ClientInfo | None,
    ) -> None:
        self.service = service
        self.motors = motors
        self.rate_hz = rate_hz
        self.callback = callback
        self.signals = signals
        self.client = client
        self.delivered = 0
        self._next: dict[int, float] = {}  # motor -> when this subscriber's next reading is due

    def due(self, device_id: int, t: float) -> bool:
        """Its own schedule: the first reading at or after each due time (2 ms of jitter allowed)."""
        due = self._next.get(device_id)
        return due is None or t >= due - 0.002

    def deliver(self, sample: Sample) -> None:
        period = 1.0 / self.rate_hz
        due = self._next.get(sample.id)
        self._next[sample.id] = sample.t + period if due is None or due + period < sample.t else due + period
        self.delivered += 1
        if self.client is not None:
            self.client.polls += 1
        self.callback(sample)

    def cancel(self) -> None:
        self.service.unsubscribe(self)


@dataclass
class _Poll:
    id: int
    rate_hz: float
    next_due: float
    failures: int = 0
    silent_since: float | None = None
    backoff: float = 0.0


@dataclass(order=True)
class _Job:
    priority: int
    seq: int
    work: Any = field(compare=False)
    future: Future[Any] = field(compare=False)
    commands: tuple[int, ...] = field(compare=False, default=())
    client: ClientInfo | None = field(compare=False, default=None)
    timeout: float | None = field(compare=False, default=None)


Work = Procedure[T] | Callable[[Bus], T]
Listener = Callable[[dict[str, Any]], None]


class BusService:
    """One bus, shared by every program's work (see the module's text).

    `motors`: the motors known at the start (ID -> the rate each answers at); more come from
    `discover`, `add_motors`, `subscribe` and commands. `say`: where the service's notices go
    (a lost port, a callback that failed)."""

    def __init__(
        self,
        bus: Bus,
        clock: Clock | None = None,
        motors: Mapping[int, int] | None = None,
        say: Callable[[str], None] | None = None,
        product: str = "mc",
        stop_window: float = STOP_VERIFY,
        program: str = "nurimc",
        say_port: bool = True,
    ) -> None:
        self.bus = bus
        #: say a lost port and its return (False: the holder program's own outage guard says them)
        self.say_port = say_port
        self.clock: Clock = clock or bus.clock
        self.product = product
        self.stop_window = stop_window
        self.known: dict[int, int] = dict(motors or {})
        self.rates_seen: set[int] = {bus.baudrate, *self.known.values()}
        self.latched: set[int] = set()
        self.stop_pending = False  # a stop asked while the port was lost: carried out on its return
        self.generation = 0  # bumped by every emergency stop
        self.reads = 0
        self.say = say or (lambda text: None)
        #: where more motors come from at each emergency stop (a holder program's own list), if anywhere
        self.motor_source: Callable[[], Mapping[int, int]] | None = None
        self._cond = threading.Condition(threading.RLock())
        self._queue: list[_Job] = []
        self._seq = itertools.count()
        self._subs: list[Subscription] = []
        self._polls: dict[int, _Poll] = {}
        self._listeners: list[Listener] = []
        self._handles: dict[int, Motor] = {}
        self._stop_asked = threading.Event()
        self._closed = False
        self._thread: threading.Thread | None = None
        self._worker: int | None = None  # the thread id carrying out work right now
        self._polling = False
        self.outage = OutageGuard(bus.transport, self._port_notice)
        self._clients = itertools.count(1)
        self.clients: dict[int, ClientInfo] = {}
        self.me = self.add_client(program, os.getpid())

    # -- programs ----------------------------------------------------------------------
    def add_client(self, program: str, pid: int) -> ClientInfo:
        info = ClientInfo(program, pid, time.time(), key=next(self._clients))
        with self._cond:
            self.clients[info.key] = info
        return info

    def remove_client(self, info: ClientInfo) -> None:
        with self._cond:
            self.clients.pop(info.key, None)
            for sub in [s for s in self._subs if s.client is info]:
                self._unsubscribe_locked(sub)

    def client_list(self) -> list[dict[str, Any]]:
        with self._cond:
            return [c.as_dict() for c in self.clients.values()]

    # -- notices -----------------------------------------------------------------------
    def listen(self, listener: Listener) -> Callable[[], None]:
        """Events for every program: estop, no_answer, answering, port (dicts with a "type")."""
        with self._cond:
            self._listeners.append(listener)

        def unlisten() -> None:
            with self._cond:
                if listener in self._listeners:
                    self._listeners.remove(listener)

        return unlisten

    def announce(self, event: dict[str, Any]) -> None:
        """Tell every program an event of the holder's own (its own emergency stop: the console's
        button, the bridge's estop topic), as the service's own events are told."""
        if event.get("type") == "estop":
            with self._cond:
                self.latched.update(int(i) for i in event.get("stopped", ()))
                self.latched.update(int(i) for i in event.get("not_confirmed", ()))
        self._tell(event)

    def _tell(self, event: dict[str, Any]) -> None:
        with self._cond:
            listeners = list(self._listeners)
        for listener in listeners:
            try:
                listener(event)
            except Exception as error:  # one program's bug never stops the bus
                self.say(f"a listener failed on {event.get('type')}: {type(error).__name__}: {error}")

    def _port_notice(self, text: str) -> None:
        if self.say_port:
            self.say(text)
        self._tell({"type": "port", "text": text, "up": not self.outage.down})
        with self._cond:
            self._cond.notify_all()

    # -- motors ------------------------------------------------------------------------
    def add_motors(self, motors: Mapping[int, int]) -> None:
        """Motors and the rate each answers at (from discovery, or given)."""
        with self._cond:
            for device_id, rate in motors.items():
                if self.known.get(device_id) != rate:
                    self._handles.pop(device_id, None)
                self.known[device_id] = rate
                self.rates_seen.add(rate)

    def adopt(self, motor: Motor) -> None:
        """Use the program's own handle of a motor (one handle per ID: its multi-turn tracker's history)."""
        with self._cond:
            self._handles[motor.id] = motor

    def forget_motor(self, device_id: int) -> None:
        with self._cond:
            self.known.pop(device_id, None)
            self._handles.pop(device_id, None)
            self.latched.discard(device_id)

    def motor(self, device_id: int) -> Motor:
        """The motor's handle, with the bus switched to its rate (call from inside a job)."""
        rate = self.known.get(device_id)
        if rate is not None and rate != self.bus.baudrate:
            self.bus.baudrate = rate
        handle = self._handles.get(device_id)
        if handle is None:
            found = self.bus.core.products.get(device_id) if self.product == "mc" else None
            handle = self._handles[device_id] = self.bus.motor(device_id, found or self.product)
        return handle

    def discover(self, rates: Iterable[int] | None = None, on_note: Callable[[Any], None] | None = None) -> list[Found]:
        """Discovery as a command job; what it finds becomes known (and is stopped by an estop)."""
        rate_list = tuple(rates) if rates is not None else None

        def work(bus: Bus) -> list[Found]:
            found: list[Found] = bus.run(discover(bus.core, rate_list), on_note=self._noting(on_note))
            self.add_motors({f.id: f.baudrate for f in found})
            return found

        return self.run(work)

    # -- subscriptions -------------------------------------------------------------------
    def subscribe(
        self,
        motors: Iterable[int],
        rate_hz: float,
        callback: Callable[[Sample], None],
        signals: Iterable[str] = ("state",),
        client: ClientInfo | None = None,
    ) -> Subscription:
        """Readings of `motors` at `rate_hz` (at most; the wire decides), to `callback`."""
        if not rate_hz > 0:
            raise ValueError(f"subscribe: rate {rate_hz!r} Hz must be above 0")
        ids = tuple(sorted(set(motors)))
        sub = Subscription(self, ids, float(rate_hz), callback, tuple(signals), client)
        with self._cond:
            for device_id in ids:
                if device_id not in self.known:
                    self.known[device_id] = self.bus.baudrate
            self._subs.append(sub)
            self._replan()
            self._cond.notify_all()
        return sub

    def unsubscribe(self, sub: Subscription) -> None:
        with self._cond:
            self._unsubscribe_locked(sub)

    def _unsubscribe_locked(self, sub: Subscription) -> None:
        if sub in self._subs:
            self._subs.remove(sub)
            self._replan()

    def _replan(self) -> None:
        """Each subscribed motor read at the highest rate anyone asked for."""
        wanted: dict[int, float] = {}
        for sub in self._subs:
            for device_id in sub.motors:
                wanted[device_id] = max(wanted.get(device_id, 0.0), sub.rate_hz)
        now = self.clock.now()
        for device_id in list(self._polls):
            if device_id not in wanted:
                del self._polls[device_id]
        for device_id, rate in wanted.items():
            poll = self._polls.get(device_id)
            if poll is None:
                self._polls[device_id] = _Poll(device_id, rate, now)
            else:
                poll.rate_hz = rate

    def offer(self, state: MotorState) -> None:
        """A reading the holder program made itself (the bridge's loop): handed to the
        subscribers of that motor as if polled, and the motor's next poll put off by one period,
        so the bus is not read twice for the same due time (polls are shared with the holder)."""
        now = self.clock.now()
        with self._cond:
            poll = self._polls.get(state.id)
            if poll is not None:
                poll.next_due = max(poll.next_due, now + 1.0 / poll.rate_hz)
                poll.failures, poll.silent_since, poll.backoff = 0, None, 0.0
        self._fan_out(Sample(state.id, now, state))

    @property
    def poll_rates(self) -> dict[int, float]:
        with self._cond:
            return {p.id: p.rate_hz for p in self._polls.values()}

    # -- jobs ----------------------------------------------------------------------------
    def submit(
        self,
        work: Work[T],
        priority: int = COMMAND,
        commands: Iterable[int] = (),
        client: ClientInfo | None = None,
        timeout: float | None = None,
    ) -> Future[T]:
        """Queue a job: a procedure (run on the bus) or a callable given the bus. `commands`: the
        motors it commands (their stop latch clears when it runs)."""
        future: Future[T] = Future()
        with self._cond:
            if self._closed:
                raise ServiceClosed("the bus service has ended")
            if priority != ESTOP and len(self._queue) >= MAX_QUEUED:
                raise QueueFull(f"the bus has {len(self._queue)} jobs waiting; try again when they are done")
            job = _Job(priority, next(self._seq), work, future, tuple(commands), client or self.me, timeout)
            heapq.heappush(self._queue, job)
            self._cond.notify_all()
        return future

    def run(
        self,
        work: Work[T],
        priority: int = COMMAND,
        commands: Iterable[int] = (),
        client: ClientInfo | None = None,
        timeout: float | None = None,
    ) -> T:
        """Carry out a job and return its result (or raise its error). From inside a job (a
        listener, a callback) it runs at once; with a worker thread it waits for it; without one
        the caller steps the service until the job is done."""
        if self._worker == threading.get_ident():
            job = _Job(priority, -1, work, Future(), tuple(commands), client or self.me, timeout)
            return self._execute(job)  # type: ignore[no-any-return]
        future = self.submit(work, priority, commands, client, timeout)
        if self._thread is not None:
            return future.result()
        while not future.done():
            if not self.step():
                self._idle_until(self.next_due())
        return future.result()

    def emergency_stop(self, client: ClientInfo | None = None) -> StopResult:
        """The one emergency stop: every job queued before it fails with Cancelled, then control
        off at every rate seen, read back (spec/host.json's window); latched for every motor."""
        with self._cond:
            self.generation += 1
            self._stop_asked.set()
            dropped, self._queue = self._queue, [j for j in self._queue if j.priority == ESTOP]
            heapq.heapify(self._queue)
        for job in dropped:
            if job.priority != ESTOP:
                job.future.set_exception(Cancelled("cancelled: an emergency stop came after it was asked"))
        who = (client or self.me).program
        return self.run(lambda bus: self._stop_work(bus, who), priority=ESTOP, client=client)

    def _stop_work(self, bus: Bus, who: str | None = None) -> StopResult:
        self._stop_asked.clear()
        if self.motor_source is not None:  # the holder program's own list (the console's discovered motors)
            self.add_motors(self.motor_source())
        with self._cond:
            known = dict(self.known)
        motors: dict[int, tuple[MotorProcedures, int]] = {}
        for device_id, rate in known.items():
            motors[device_id] = (self._handle_only(device_id).procedures, rate)
        rates = tuple(sorted(self.rates_seen))
        try:
            result = bus.run(emergency_stop(bus.core, motors, self.stop_window, rates), on_note=self._stop_note)
        except PortLost as lost:
            self._latch_pending(lost)
            result = StopResult((), tuple(sorted(known)), rates, {str(i): f"unknown: {lost}" for i in known})
        else:
            self.stop_pending = False
            transport = reconnecting(bus.transport)
            if transport is not None:
                transport.on_return("estop", None)
        with self._cond:
            self.latched |= set(known)
            result = replace(result, latched=tuple(sorted(self.latched)))
        said = {"from": who} if who else {}  # which program asked (a holder does not report its own stop twice)
        self._tell({"type": "estop", "generation": self.generation, **said, **result.as_dict()})
        return result

    def _handle_only(self, device_id: int) -> Motor:
        handle = self._handles.get(device_id)
        if handle is None:
            found = self.bus.core.products.get(device_id) if self.product == "mc" else None
            handle = self._handles[device_id] = self.bus.motor(device_id, found or self.product)
        return handle

    def _stop_note(self, note: object) -> None:
        """Between read-backs the polls that fall due go on (multi-turn tracking keeps its turns)."""
        if not isinstance(note, Idle):
            return
        while True:
            self._poll_due(self.clock.now())
            due = self.next_due()
            if due is None or due >= note.until:
                return
            if due > self.clock.now():
                self.clock.sleep(due - self.clock.now())

    def _latch_pending(self, lost: PortLost) -> None:
        self.stop_pending = True
        transport = reconnecting(self.bus.transport)
        if transport is not None:
            transport.on_return("estop", SetControl(BROADCAST_ID, 1).encode())
        self._tell({"type": "estop_pending", "message": f"stop pending: port lost: {lost}"})

    def _noting(self, on_note: Callable[[Any], None] | None) -> Callable[[Any], None]:
        def note(event: Any) -> None:
            if self._stop_asked.is_set():
                raise Interrupted("interrupted by the emergency stop")
            if on_note is not None:
                on_note(event)

        return note

    def _execute(self, job: _Job) -> Any:
        work = job.work
        if job.client is not None:
            job.client.requests += 1
        if inspect.isgenerator(work):
            result = self.bus.run(cast(Procedure[Any], work), on_note=self._noting(None), timeout=job.timeout)
        else:
            result = work(self.bus)
        if job.commands:
            with self._cond:
                self.latched.difference_update(job.commands)
        return result

    # -- stepping ------------------------------------------------------------------------
    def step(self) -> bool:
        """Do one unit of work: the next job, or the reads that are due. False: nothing to do now."""
        with self._cond:
            if self._closed:
                return False
        if self.outage.returned():  # before taking a job: a job taken here would be lost
            self._after_return()
            return True
        with self._cond:
            job = heapq.heappop(self._queue) if self._queue else None
        if job is not None:
            self._carry_out(job)
            return True
        return self._poll_due(self.clock.now())

    def _carry_out(self, job: _Job) -> None:
        if job.future.done():
            return
        self._worker = threading.get_ident()
        try:
            result = self._execute(job)
        except BaseException as error:  # handed to whoever asked; the service goes on
            if not job.future.done():
                job.future.set_exception(error)
            if not isinstance(error, Exception):
                raise
        else:
            if not job.future.done():
                job.future.set_result(result)
        finally:
            self._worker = None

    def next_due(self) -> float | None:
        """When the next read is due (None: nothing subscribed; now: a job waits)."""
        with self._cond:
            if self._queue:
                return self.clock.now()
            if not self._polls:
                return None
            return min(p.next_due for p in self._polls.values())

    def _idle_until(self, when: float | None, limit: float | None = None) -> None:
        now = self.clock.now()
        end = when if when is not None else (limit if limit is not None else now + OUTAGE_RECHECK)
        if end <= now:  # due, but nothing could be done (the port is down): look again a little later
            end = now + OUTAGE_RECHECK
        if limit is not None:
            end = min(end, limit)
        if end > now:
            self.clock.sleep(end - now)

    def run_until(self, when: float) -> None:
        """Do what is due until the clock reaches `when` (the caller's loop, on any clock)."""
        while self.clock.now() < when and not self._closed:
            if not self.step():
                self._idle_until(self.next_due(), when)

    def run_for(self, seconds: float) -> None:
        self.run_until(self.clock.now() + seconds)

    def _poll_due(self, now: float) -> bool:
        if self._polling:
            return False
        if self.outage.down:
            return False
        with self._cond:
            due = sorted((p for p in self._polls.values() if p.next_due <= now), key=lambda p: p.next_due)
        if not due:
            return False
        self._polling = True
        previous, self._worker = self._worker, threading.get_ident()
        try:
            for poll in due:
                with self._cond:
                    if self._queue and self._queue[0].priority == ESTOP:
                        break  # the stop goes first
                if not self._read(poll):
                    break
        finally:
            self._polling = False
            self._worker = previous
        return True

    def _read(self, poll: _Poll) -> bool:
        """Read one motor and hand the sample out; False when the port is lost (polling pauses)."""
        silent = poll.silent_since is not None
        try:
            motor = self.motor(poll.id)
            procedures = motor.procedures
            state = self.bus.run(read_state_once(procedures) if silent else procedures.read_state())
        except PortLost:
            return False
        except NurimcError as error:
            now = self.clock.now()
            poll.failures += 1
            if poll.failures >= SILENT_AFTER:
                if poll.silent_since is None:
                    poll.silent_since = now
                    self._tell({"type": "no_answer", "id": poll.id, "since": now, "message": str(error)})
                poll.backoff = min(BACKOFF_MAX, poll.backoff * 2 if poll.backoff else BACKOFF_FIRST)
                poll.next_due = now + poll.backoff
            else:
                poll.next_due = now + 1.0 / poll.rate_hz
            self._fan_out(Sample(poll.id, now, None, str(error), poll.silent_since))
            return True
        now = self.clock.now()
        self.reads += 1
        if silent:
            self._tell({"type": "answering", "id": poll.id, "since": poll.silent_since})
        poll.failures, poll.silent_since, poll.backoff = 0, None, 0.0
        period = 1.0 / poll.rate_hz
        poll.next_due = poll.next_due + period
        if poll.next_due < now - period:  # fell behind (a long job): no burst to catch up
            poll.next_due = now
        self._fan_out(Sample(poll.id, now, state))
        return True

    def _fan_out(self, sample: Sample) -> None:
        with self._cond:
            subs = [s for s in self._subs if sample.id in s.motors and s.due(sample.id, sample.t)]
        for sub in subs:
            try:
                sub.deliver(sample)
            except Exception as error:  # a subscriber's bug never stops the bus
                self.say(f"a subscriber failed on ID {sample.id}: {type(error).__name__}: {error}")

    def _after_return(self) -> None:
        """The port is back: a latched stop first (its broadcast already went first), then
        every known motor read again before anything else."""
        self._tell({"type": "port", "text": "resumed", "up": True})
        if self.stop_pending:
            self._worker = threading.get_ident()
            try:
                self._stop_work(self.bus)
            finally:
                self._worker = None
        with self._cond:
            for poll in self._polls.values():
                poll.next_due = min(poll.next_due, self.clock.now())
        self._poll_due(self.clock.now())

    # -- the thread ----------------------------------------------------------------------
    def start(self) -> BusService:
        """Carry out the work in a thread of its own (real-time programs)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="nurimc-bus-service", daemon=True)
            self._thread.start()
        return self

    def _loop(self) -> None:
        while True:
            with self._cond:
                if self._closed:
                    break
            try:
                worked = self.step()
            except Exception as error:  # never leave the bus without its thread
                self.say(f"bus service: {type(error).__name__}: {error}")
                worked = False
            if worked:
                continue
            with self._cond:
                if self._closed or self._queue:
                    continue
                due = self.next_due()
                delay = OUTAGE_RECHECK if due is None or self.outage.down else due - self.clock.now()
                if delay > 0:
                    self._cond.wait(min(delay, 1.0))

    def close(self) -> None:
        """End the service: waiting jobs fail with ServiceClosed; the bus is left open (its owner closes it)."""
        with self._cond:
            if self._closed:  # closed already (by its holder and by the program using it)
                return
            self._closed = True
            waiting, self._queue = self._queue, []
            self._cond.notify_all()
        for job in waiting:
            if not job.future.done():
                job.future.set_exception(ServiceClosed("the bus service has ended"))
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5)
        self._tell({"type": "closed"})
        self.outage.close()

    def __enter__(self) -> BusService:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
