"""The one thread that talks to the bus: commands from the pages, and polling between them.

RS485 is half-duplex and the Bus runs one procedure at a time, so everything goes through this
thread. The scheduler (scheduler.py) decides which page's command is next (the emergency stop
first, then the pages in turn); this module carries each out (the handlers) and, between
commands, reads the watched motors' states as fast as the wire allows (capped at POLL_HZ). The
reads are a subscription of a bus service's poll schedule (service/core.py, docs/service.md):
this thread steps that service between commands and while a stop reads back, and the service
decides which motor is due (a motor that stops answering is read less often).

Port loss (a bus opened with reconnect, docs/dashboard.md "Port lost"): polling pauses, every
command fails at once with the reason, an emergency stop is latched ("stop pending: port
lost") and its broadcast registered to be the first frame when the port returns; on the return
the stop is carried out and read back, then every known motor's state is read again before any
other command goes out. Nothing asked during the outage is replayed.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..drivers.sync import Bus
from ..errors import NurimcError, PortError, PortLost
from ..procedures import config
from ..procedures.discovery import Found, Progress, discover
from ..procedures.motor import Motor, MotorState
from ..procedures.stepresponse import analyse
from ..protocol import BROADCAST_ID, FieldRangeError, SetControl
from ..protocol.host import LIMITS, STOP_VERIFY
from ..service.backoff import Backoff
from ..service.core import COMMAND, BusService, Interrupted, Sample, Subscription
from ..transport.reconnect import PortEvent, reconnecting
from . import commands as c
from . import tune_panel
from .procedures import Reading, emergency_stop, gains_at_start, probe_port, set_zero, step_run
from .scheduler import CANCELLED, MAX_PENDING, Done, Job, Scheduler

POSITION_LIMIT = LIMITS["position_deg"]  # the largest target a position command can carry, degrees

POLL_HZ = 200.0  # at most this many reads of each watched motor per second
ESTOP_VERIFY_SECONDS = STOP_VERIFY  # spec/host.json "stop": the one window of every stop (docs/service.md)
ERROR_REPEAT = 1.0  # s between two reports of the same motor's read failure
IDLE_PROBE = 1.0  # s without any bus work before the port is looked at (a lost port is noticed in use)
DOWN_RECHECK = 1.0  # s: while the port is down the thread sleeps this long between looks (no busy loop)
STOP_PENDING = "stop pending: port lost"
BUSY_MARGIN = 0.2  # s after a controller's busy window during which a failed reading is still "busy"
REOPEN_WAIT = 3.0  # s a reopen asked from the page waits for the port before answering

__all__ = ["CANCELLED", "MAX_PENDING", "BusWorker", "Done", "KnownMotor"]


class StopPending(NurimcError):
    """An emergency stop asked while the port is lost: latched, carried out when it returns."""


@dataclass(frozen=True, slots=True)
class KnownMotor:
    id: int
    baudrate: int
    firmware: int | None

    def as_dict(self) -> dict[str, Any]:
        return {"id": self.id, "baudrate": self.baudrate, "firmware": self.firmware}


class BusWorker:
    def __init__(
        self, bus: Bus, product: str, publish: Callable[[dict[str, Any]], None], port: str = "", tracer: Any = None
    ) -> None:
        self.bus = bus
        self.port = port  # what the bus was opened on ("sim://" for the simulator)
        self.tracer = tracer
        self.product = product
        self.publish = publish  # called from any thread: progress, errors, estop and port notices
        self.motors: dict[int, KnownMotor] = {}  # kept for every page, new tabs and reloads
        self._watched: tuple[int, ...] = ()
        self._subscription: Subscription | None = None
        self.service = self._new_service()
        self.jobs = Scheduler()
        self._handles: dict[int, Motor] = {}
        self._stopping = False
        self._samples: list[list[float]] = []
        self._samples_lock = threading.Lock()
        self._last_error: dict[int, float] = {}
        self.silent = Backoff()  # motors that stopped answering: read less often, the others keep their rate
        self._busy_why: dict[int, str] = {}  # motor -> what last wrote its EEPROM (the window itself is BusCore's)
        self.clock_origin = time.monotonic()
        self.reads = 0
        #: an emergency stop asked while the port was lost, not yet carried out and read back
        self.stop_pending = False
        self._returns_seen = 0  # the transport's count of returns this thread has caught up with
        #: motors set turning by `run` (a speed with no end): stopped first if the port is lost meanwhile
        self.turning: set[int] = set()
        #: motors this console set moving or holding on its port: stopped before it leaves the port
        self.commanded: set[int] = set()
        self._watch_port()
        self._thread = threading.Thread(target=self._loop, name="nurimc-dashboard-bus", daemon=True)

    def _new_service(self) -> BusService:
        """The bus service of this console's bus, stepped by this thread (no thread of its own), on the bus's clock."""
        return BusService(
            self.bus, say=lambda _text: None, product=self.product, program="nurimc dashboard", say_port=False
        )

    @property
    def watched(self) -> tuple[int, ...]:
        """The motors read between commands: a subscription of the service's polls at POLL_HZ."""
        return self._watched

    @watched.setter
    def watched(self, ids: tuple[int, ...]) -> None:
        self._watched = tuple(ids)
        if self._subscription is not None:
            self._subscription.cancel()
            self._subscription = None
        if ids:
            self.service.add_motors({i: self.motors[i].baudrate for i in ids if i in self.motors})
            for device_id in ids:  # one handle per ID: the multi-turn tracker's history is the console's
                self.service.adopt(self._handle(device_id))
            self._subscription = self.service.subscribe(ids, POLL_HZ, self._polled)

    @property
    def generation(self) -> int:
        """Bumped by every emergency stop."""
        return self.jobs.generation

    @property
    def known(self) -> dict[int, int]:
        """Motor ID -> the rate it answers at."""
        return {m.id: m.baudrate for m in self.motors.values()}

    def motor_list(self) -> list[dict[str, Any]]:
        return [m.as_dict() for m in sorted(self.motors.values(), key=lambda m: m.id)]

    def port_state(self) -> dict[str, Any]:
        """The port as the pages show it (hello, /api/info, `port` events)."""
        transport = reconnecting(self.bus.transport)
        up = transport is None or transport.up
        state: dict[str, Any] = {"port": self.port, "up": up, "reconnect": transport is not None}
        state["stop_pending"] = self.stop_pending
        if transport is not None and not up:
            state["message"] = transport.lost_text()
        return state

    # -- from other threads ----------------------------------------------------------
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        with self.jobs.cond:
            self._stopping = True
            self.jobs.cond.notify_all()
        self._thread.join(timeout=5)
        self.service.close()
        transport = reconnecting(self.bus.transport)
        if transport is not None:
            transport.unwatch(self._port_event)
        if self.stop_pending:  # the console ends with the stop never carried out: say so
            self.publish({"type": "port", "state": "closed", **self.port_state()})

    def submit(
        self,
        command: c.Command,
        done: Done,
        owner: object = None,
        generation: int | None = None,
        received: Callable[[int], None] | None = None,
    ) -> None:
        """Queue a command; `done` is always called exactly once, from any thread (scheduler.py)."""
        self.jobs.submit(command, done, owner, generation, received)

    def forget(self, owner: object) -> None:
        """A page went away: its queued commands are dropped, not carried out for no one."""
        self.jobs.forget(owner)

    def take_samples(self) -> list[list[float]]:
        """[id, t, position, speed, current, device_position] rows read since the last call."""
        with self._samples_lock:
            out, self._samples = self._samples, []
            return out

    # -- the port ----------------------------------------------------------------------
    def _watch_port(self) -> None:
        transport = reconnecting(self.bus.transport)
        if transport is not None:
            transport.watch(self._port_event)
            self._returns_seen = transport.returns

    def _port_event(self, event: PortEvent) -> None:
        """From the thread that saw the loss or the return: tell the pages, wake the bus thread.
        A motor turning by `run` is no longer under anyone's control once the port is lost: its
        control off becomes the first frame on the return."""
        transport = reconnecting(self.bus.transport)
        if event.kind == "lost" and transport is not None:
            for device_id in sorted(self.turning):
                transport.on_return(f"stop {device_id:03d}", SetControl(device_id, 1).encode())
        message: dict[str, Any] = {"type": "port", "state": event.kind, "text": event.text}
        if event.down_for is not None:
            message["down_for"] = round(event.down_for, 3)
        self.publish({**self.port_state(), **message})
        with self.jobs.cond:
            self.jobs.cond.notify_all()

    def _port_down(self) -> bool:
        transport = reconnecting(self.bus.transport)
        return transport is not None and not transport.up

    def _caught_up(self) -> bool:
        transport = reconnecting(self.bus.transport)
        return transport is None or not transport.up or transport.returns == self._returns_seen

    def _after_return(self) -> None:
        """The port is back: the latched stop first (its broadcast already went out as the first
        frame), then every known motor's state read again; only then other commands."""
        transport = reconnecting(self.bus.transport)
        if transport is None:
            return
        self._returns_seen = transport.returns
        self.bus.core.control_released.clear()  # what was known before the outage may no longer hold
        result: dict[str, Any] = {"type": "port", "state": "resumed", **self.port_state()}
        result["stopped"], self.turning = sorted(self.turning), set()  # control off went first
        if self.stop_pending:
            try:
                result["estop"] = self._stop_now(latched=True)
            except PortLost:
                return  # gone again: the latch stays, the next return tries again
        states: dict[str, Any] = {}
        for device_id in sorted(self.motors):
            try:
                state = self._sample(device_id)
                states[str(device_id)] = {
                    "position": state.position,
                    "speed": state.speed,
                    "current": state.current,
                    "position_uncertain": state.position_uncertain,
                }
            except PortLost:
                return
            except NurimcError as error:
                states[str(device_id)] = {"error": str(error)}
        result["states"] = states
        result.update(self.port_state())
        self.publish(result)

    # -- the thread ------------------------------------------------------------------
    def _loop(self) -> None:
        next_poll = 0.0
        cond = self.jobs.cond
        while True:
            idle = False
            with cond:
                while not self._stopping and not self.jobs and not self.watched and self._caught_up():
                    if not cond.wait(IDLE_PROBE) and not self._port_down():
                        idle = True  # nothing asked for a while: look whether the port is still there
                        break
                if self._stopping:
                    break
            if idle:
                self._probe()
                continue
            with cond:
                job = None if not self._caught_up() else self.jobs.take()
                if job is None and self._caught_up():
                    delay = DOWN_RECHECK if self._port_down() else next_poll - time.monotonic()
                    if delay > 0:
                        cond.wait(delay)
                        continue
            if not self._caught_up():
                self._after_return()
            elif job is not None:
                self._carry_out(job)
            else:
                next_poll = time.monotonic() + 1.0 / POLL_HZ
                self._poll()
        self.jobs.finish_cancelled()  # every `done` is called exactly once, also on the way out

    def _probe(self) -> None:
        """An idle console notices a lost port too (a `port` event), not only at the next command."""
        with contextlib.suppress(NurimcError):
            self.bus.run(probe_port())

    def _carry_out(self, job: Job) -> None:
        command = job.command
        result: Any = None
        error: str | None = None
        if isinstance(command, c.EmergencyStop):
            self.jobs.stop_requested.clear()
        elif job.generation < self.generation:  # a stop came in after this was queued
            error = CANCELLED
        if error is None:
            try:
                result = self._through_service(command)
            except Interrupted:
                error = "interrupted by the emergency stop"
            except (NurimcError, FieldRangeError, ValueError, KeyError, ArithmeticError) as problem:
                text = problem.args[0] if isinstance(problem, KeyError) and problem.args else str(problem)
                error = str(text)
            except Exception as problem:
                error = f"internal error: {type(problem).__name__}: {problem}"
        job.finish(result, error)
        if isinstance(command, c.EmergencyStop):
            self.jobs.finish_cancelled()

    def _through_service(self, command: c.Command) -> Any:
        """A page's command as a COMMAND job of the bus service (the stop and a port switch are the
        worker's own: the stop is the service's emergency stop, a switch replaces the service)."""
        if isinstance(command, c.EmergencyStop | c.OpenBus):
            return self._execute(command)
        device_id = getattr(command, "id", None)
        commands = [device_id] if isinstance(command, c.Move | c.RunMotor | c.HoldMotor) and device_id else []
        return self.service.run(lambda _bus: self._execute(command), priority=COMMAND, commands=commands)

    def _poll(self) -> None:
        """The reads that are due (the service's schedule; PortLost pauses them until the port is back)."""
        self.service.step()

    def _polled(self, sample: Sample) -> None:
        """A reading from the service's polls: plotted, or its failure said (at most every ERROR_REPEAT s)."""
        device_id = sample.id
        if sample.state is not None:
            if self.silent.answered(device_id) is not None:
                self.publish({"type": "motor_answering", "id": device_id})
            self._plot(sample.state)
            return
        # a motor that stopped answering is read less often by the service (service/backoff.py): said once
        if self.silent.failed(device_id, self.bus.clock.now()):
            self.publish({"type": "motor_silent", "id": device_id})
        now = time.monotonic()
        why = self._busy_why.get(device_id, "")
        error = sample.error or f"ID {device_id} did not answer"
        busy = "busy writing its settings" in error  # a ControllerBusy's text
        if now < self.bus.core.busy_until(device_id) + BUSY_MARGIN or busy:
            text = f"ID {device_id} is busy writing its settings{why}; readings resume in a moment"
            kind = "busy"
        else:
            text, kind = error, "error"
        if now - self._last_error.get(device_id, 0.0) >= ERROR_REPEAT:
            self._last_error[device_id] = now
            self.publish({"type": "motor_error", "id": device_id, "message": text, "kind": kind})

    def _sample(self, device_id: int) -> MotorState:
        """Read one motor's state and queue it for the plots."""
        state = self.motor(device_id).read_state()
        if self.silent.answered(device_id) is not None:
            self.publish({"type": "motor_answering", "id": device_id})
        self._plot(state)
        return state

    def _plot(self, state: MotorState) -> None:
        device_id = state.id
        self.reads += 1
        t = round(time.monotonic() - self.clock_origin, 4)
        # the 7th column: 1 when the continuous position may be off by whole turns (nurimc.procedures.multiturn)
        row = [device_id, t, state.position, state.speed, state.current, state.device_position]
        row.append(1 if state.position_uncertain else 0)
        with self._samples_lock:
            self._samples.append(row)

    def motor(self, device_id: int) -> Motor:
        """The motor's handle, with the bus switched to its rate."""
        known = self.motors.get(device_id)
        if known is not None and known.baudrate != self.bus.baudrate:
            self.bus.baudrate = known.baudrate
        return self._handle(device_id)

    def _handle(self, device_id: int) -> Motor:
        if device_id not in self._handles:
            # the product line discovery found for the ID (nurimc.procedures.products) beats the default "mc"
            found = self.bus.core.products.get(device_id) if self.product == "mc" else None
            self._handles[device_id] = self.bus.motor(device_id, found or self.product)
            self.service.adopt(self._handles[device_id])  # the service's polls read through it too
        return self._handles[device_id]

    def _wrote_eeprom(self, device_id: int, why: str) -> None:
        """What is about to write this controller's EEPROM: while the BusCore's busy window for it
        lasts, a reading that fails says so instead of blaming the wiring."""
        self._busy_why[device_id] = why

    def _check_estop(self) -> None:
        if self.jobs.stop_requested.is_set():
            raise Interrupted

    # -- commands --------------------------------------------------------------------
    def _execute(self, command: c.Command) -> Any:
        match command:
            case c.Discover(rates):
                return self._discover(rates)
            case c.Watch(ids):
                self.watched = ids
                return {"watching": list(ids)}
            case c.Move(device_id, degrees, rpm, seconds, relative):
                motor = self.motor(device_id)
                self._wrote_eeprom(device_id, " (control on)")
                (motor.move_by if relative else motor.move_to)(degrees, rpm=rpm, seconds=seconds)
                self.turning.discard(device_id)  # a move ends by itself
                self.commanded.add(device_id)
                return {"id": device_id}
            case c.RunMotor(device_id, rpm, ramp):
                self._wrote_eeprom(device_id, " (control on)")
                self.motor(device_id).run(rpm, ramp)
                self.turning.add(device_id)
                self.commanded.add(device_id)
                return {"id": device_id}
            case c.Release(device_id):
                self._wrote_eeprom(device_id, " after the release")
                self.motor(device_id).release()
                self.turning.discard(device_id)
                self.commanded.discard(device_id)  # control off: not driven any more
                return {"id": device_id, "control": "off"}
            case c.HoldMotor(device_id):
                self._wrote_eeprom(device_id, " (control on)")
                self.motor(device_id).hold()
                self.turning.discard(device_id)
                self.commanded.add(device_id)
                return {"id": device_id}
            case c.ReadSettings(device_id):
                return {"id": device_id, "settings": self.motor(device_id).read_settings()}
            case c.WriteSetting(device_id, name, value):
                self._wrote_eeprom(device_id, f" ({name})")
                verified = self.motor(device_id).set(name, value)  # writes, then reads back until it matches
                return {"id": device_id, "name": name, "value": verified, "verified": True}
            case c.Step():
                return self._step(command)
            case c.Backup(ids):
                return self._backup(ids)
            case c.Restore(document):
                return self._restore(document)
            case c.SetZero(device_id):
                return self._set_zero(device_id)
            case c.ChangeId(device_id, new_id):
                return self._change_id(device_id, new_id)
            case c.ChangeBaud(device_id, rate):
                return self._change_baud(device_id, rate)
            case c.FactoryResetMotor(device_id):
                return self._factory_reset(device_id)
            case c.Ports():
                return {"ports": self._ports(), "current": self.port, "baudrate": self.bus.baudrate}
            case c.OpenBus(port, rate):
                return self._open_bus(port, rate)
            case c.EmergencyStop():
                return self._emergency_stop()
            case tune_panel.Tune():
                return tune_panel.run_tune(self, command)
        raise ValueError(f"the bus worker cannot carry out {command!r}")

    def _discover(self, rates: tuple[int, ...] | None) -> dict[str, Any]:
        seen: set[int] = set()

        def progress(event: object) -> None:
            self._check_estop()
            if isinstance(event, Progress):
                for f in event.found:  # cards appear as motors are found, in every page
                    if f.id not in seen:
                        seen.add(f.id)
                        self._remember(f)
                self.publish(
                    {
                        "type": "progress",
                        "rate": event.rate,
                        "index": event.rate_index,
                        "total": event.rates_total,
                        "walking_id": event.walking_id,
                        "found": [f.id for f in event.found],
                        "motors": self.motor_list(),
                    }
                )

        self.watched = ()
        found = self.bus.run(discover(self.bus.core, rates), on_note=progress)
        scanned = set(rates) if rates is not None else None
        for device_id, known in list(self.motors.items()):  # gone from a rate that was scanned
            if (scanned is None or known.baudrate in scanned) and device_id not in {f.id for f in found}:
                del self.motors[device_id]
        for f in found:
            self._remember(f)
        self.watched = tuple(sorted(self.motors))
        motors = [{"id": f.id, "baudrate": f.baudrate, "firmware": f.firmware} for f in found]
        self.publish({"type": "motors", "motors": self.motor_list(), "generation": self.generation})
        return {"motors": motors, "known": self.motor_list()}

    def _remember(self, f: Found) -> None:
        old = self.motors.get(f.id)
        if old is not None and old.baudrate != f.baudrate:
            self._handles.pop(f.id, None)
            self.service.forget_motor(f.id)
        firmware = f.firmware if f.firmware is not None else (old.firmware if old else None)
        self.motors[f.id] = KnownMotor(f.id, f.baudrate, firmware)

    def _step(self, step: c.Step) -> dict[str, Any]:
        motor = self.motor(step.id)
        start = motor.read_state().device_position
        target = round(start + step.amplitude, 2)
        if abs(target) > POSITION_LIMIT:
            raise ValueError(
                f"step: the target {target:.2f} deg is past the device's position range ±{POSITION_LIMIT} deg "
                f"(the motor is at {start:.2f} deg in the device's frame); use a smaller step, "
                "move back, or set zero here first"
            )
        gains = self.bus.run(gains_at_start(motor.procedures))  # the run's label: what the motor has
        self._wrote_eeprom(step.id, " (control on)")

        def progress(event: object) -> None:  # each reading as it comes: the plots, and the stop's chance
            self._check_estop()
            if isinstance(event, Reading):
                self._plot(event.state)

        readings = self.bus.run(step_run(motor.procedures, target, step.rpm, step.duration), on_note=progress)
        times = [0.0, *(round(r.t, 4) for r in readings)]
        positions = [start, *(r.state.device_position for r in readings)]
        figures = analyse(times, positions, start, target)
        return {
            "id": step.id,
            "start": start,
            "target": target,
            "times": times,
            "positions": positions,
            "rise_time": figures.rise_time,
            "overshoot": figures.overshoot,
            "settled": figures.settled,
            "final_error": figures.final_error,
            "gains": gains,
        }

    def _backup(self, ids: tuple[int, ...]) -> dict[str, Any]:
        document: dict[str, Any] | None = None
        for device_id in ids:
            part = self.bus.run(config.backup([self.motor(device_id).procedures]))
            if document is None:
                document = part
            else:
                document["motors"].extend(part["motors"])
        if document is None:
            raise ValueError("backup: give at least one motor")
        return document

    def _restore(self, document: dict[str, Any]) -> dict[str, Any]:
        changed: list[str] = []
        for entry in document["motors"]:
            self._check_estop()
            single = {**document, "motors": [entry]}
            self._wrote_eeprom(entry["id"], " (restore)")
            changed += self.bus.run(config.restore([self.motor(entry["id"]).procedures], single))
        return {"changed": changed}

    def _set_zero(self, device_id: int) -> dict[str, Any]:
        motor = self.motor(device_id)
        state = self.bus.run(set_zero(self.bus.core, motor.procedures))
        return {"id": device_id, "device_position": state.device_position, "position": state.position}

    def _change_id(self, device_id: int, new_id: int) -> dict[str, Any]:
        if new_id in self.motors:
            raise ValueError(f"ID {new_id} is already taken by a known motor; pick a free ID")
        motor = self.motor(device_id)
        self._wrote_eeprom(device_id, " (new ID)")
        self.bus.run(config.change_id(self.bus.core, device_id, new_id))  # refuses a taken ID, verifies
        old = self.motors.pop(device_id, KnownMotor(device_id, self.bus.baudrate, None))
        self._handles.pop(device_id, None)
        self.service.forget_motor(device_id)
        del motor
        self.motors[new_id] = KnownMotor(new_id, old.baudrate, old.firmware)
        self._forget_watch(device_id, new_id)
        self.publish({"type": "motors", "motors": self.motor_list(), "generation": self.generation})
        return {"id": device_id, "new_id": new_id}

    def _change_baud(self, device_id: int, rate: int) -> dict[str, Any]:
        self.motor(device_id)  # the bus at its current rate
        self._wrote_eeprom(device_id, " (new baud rate)")
        answered = self.bus.run(config.change_baud(self.bus.core, device_id, rate))  # verifies, finds it if lost
        old = self.motors.get(device_id)
        self.motors[device_id] = KnownMotor(device_id, answered, old.firmware if old else None)
        self.publish({"type": "motors", "motors": self.motor_list(), "generation": self.generation})
        return {"id": device_id, "baudrate": answered}

    def _factory_reset(self, device_id: int) -> dict[str, Any]:
        self.motor(device_id)
        self.bus.run(config.factory_reset(self.bus.core, device_id, confirm=True))
        self.motors.pop(device_id, None)
        self._handles.pop(device_id, None)
        self.service.forget_motor(device_id)
        self._forget_watch(device_id, None)
        self.publish({"type": "motors", "motors": self.motor_list(), "generation": self.generation})
        return {"id": device_id, "note": "it comes back as ID 0 at 9600 bps: discover again at 9600"}

    def _ports(self) -> list[str]:
        names = [self.port] if self.port else []
        if not self.port.startswith("sim"):
            from serial.tools import list_ports

            names += [p.device for p in list_ports.comports() if p.device not in names]
        return names

    def _open_bus(self, port: str, rate: int) -> dict[str, Any]:
        """Switch the port, or reopen the same one (a lost adapter, at once rather than at the next
        retry). The new bus reconnects by itself too. A latched stop is carried out on it first."""
        if self.port.startswith("sim"):
            if port == self.port:
                self.bus.baudrate = rate
                return {"port": port, "baudrate": rate}
            raise ValueError("this console runs on the simulated bus (--sim); restart it with --port for a real port")
        if port == self.port and not self._port_down():
            self.bus.baudrate = rate
            return {"port": port, "baudrate": rate}
        if port == self.port:  # lost: try the same path now, the reconnect carries on if it fails
            return self._reopen_now(port, rate)
        left = self._stop_before_leaving()
        old = self.bus
        new = Bus.open(port, baudrate=rate, tracer=self.tracer, reconnect=True)  # PortError says what is wrong
        old_transport = reconnecting(old.transport)
        if old_transport is not None:
            old_transport.unwatch(self._port_event)
        self.watched = ()
        self.service.close()  # the service is of one bus: a new one on the new port
        self.bus, self.port = new, port
        old.close()
        self._handles.clear()
        self.service = self._new_service()
        self._watch_port()
        result: dict[str, Any] = {"port": port, "baudrate": rate, **left}
        if self.stop_pending:  # asked for the motors of the lost port: on this one, as far as it reaches
            result["estop"] = self._stop_now(latched=True)
        self.motors.clear()
        self.watched = ()
        self.publish({"type": "motors", "motors": [], "generation": self.generation})
        self.publish({"type": "port", "state": "opened", **self.port_state()})
        return result

    def _stop_before_leaving(self) -> dict[str, Any]:
        """Port switching is a stop first: every motor this console commanded on the port it
        leaves is stopped and read back off, or the switch is refused with those motors named.
        With the port lost, the switch goes on and names them (the latched stop still waits)."""
        ids = sorted(self.commanded)
        if not ids:
            return {}
        motors = {i: (self._handle(i).procedures, self.known.get(i, self.bus.baudrate)) for i in ids}
        try:
            result = self.bus.run(emergency_stop(self.bus.core, motors))
        except PortLost:
            return {"not_stopped": ids}
        if result["not_confirmed"]:
            names = ", ".join(map(str, result["not_confirmed"]))
            raise ValueError(
                f"cannot leave {self.port}: ID {names} did not read back off after control off (the port was "
                "not switched); stop them (or cut their power), then switch"
            )
        self.commanded.clear()
        self.turning.clear()
        return {"stopped_before_leaving": result["stopped"]}

    def _reopen_now(self, port: str, rate: int) -> dict[str, Any]:
        transport = reconnecting(self.bus.transport)
        assert transport is not None
        transport.baudrate = rate
        transport.retry_now()
        if not transport.wait_up(REOPEN_WAIT):
            raise PortError(
                f"cannot reopen {port}: {transport.last_attempt_error or 'not back yet'}; "
                "still retrying in the background (plug the adapter back in, or open another port)"
            )
        return {"port": port, "baudrate": rate, "reopened": True}  # the return is handled next: stop, re-read

    def _forget_watch(self, old: int, new: int | None) -> None:
        ids = [i for i in self.watched if i != old]
        if new is not None:
            ids.append(new)
        self.watched = tuple(sorted(ids))

    def _emergency_stop(self) -> dict[str, Any]:
        """Control off everywhere, read back; with the port lost: latched until it returns."""
        try:
            return self._stop_now()
        except PortLost as lost:
            self._latch_stop(lost)
            raise StopPending(
                f"{STOP_PENDING}: {lost}. The stop is latched: it is the first frame sent when the port "
                "returns, then read back; if the motors must stop now, cut their power"
            ) from lost

    def _latch_stop(self, lost: PortLost) -> None:
        transport = reconnecting(self.bus.transport)
        self.stop_pending = True
        if transport is not None:
            transport.on_return("estop", SetControl(BROADCAST_ID, 1).encode())
        self.publish({"type": "estop_pending", "message": f"{STOP_PENDING}: {lost}", "generation": self.generation})

    def _stop_now(self, latched: bool = False) -> dict[str, Any]:
        """Control off, broadcast at every rate a motor was found at, then each motor told and checked.

        A controller busy writing its EEPROM (after a hold or a setting, 50-300 ms) ignores frames,
        so a broadcast can be lost on it: each motor is read back and told again until it reads
        "off" or ESTOP_VERIFY_SECONDS pass (then it is reported as not confirmed).
        """
        if self._port_down():
            raise PortLost(reconnecting(self.bus.transport).lost_text())  # type: ignore[union-attr]
        for device_id in self.known:
            self._wrote_eeprom(device_id, " after the emergency stop")
        for device_id in set(self.service.known) - set(self.motors):  # forgotten here: not the service's either
            self.service.forget_motor(device_id)
        self.service.add_motors(self.known)
        # the rates to broadcast at: those the console found motors at (and the present one), as before
        self.service.rates_seen = set(self.known.values())
        for device_id in self.motors:  # the console's handles (one per ID)
            self.service.adopt(self._handle(device_id))
        # the service's one emergency stop: its polls go on between read-backs (issue 37)
        stop = self.service.emergency_stop()
        if self.service.stop_pending:  # lost during the stop: latched once, by this worker (below)
            self.service.stop_pending = False
            transport = reconnecting(self.bus.transport)
            raise PortLost(transport.lost_text() if transport is not None else "the port is lost")
        result: dict[str, Any] = {
            "rates": list(stop.rates),
            "control": stop.control,
            "stopped": list(stop.stopped),
            "not_confirmed": list(stop.not_confirmed),
            "ok": stop.ok,
        }
        if latched:
            self.stop_pending = False
            transport = reconnecting(self.bus.transport)
            if transport is not None:
                transport.on_return("estop", None)
        self.turning.clear()
        self.commanded.difference_update(result.get("stopped", []))
        result.update(generation=self.generation, latched=latched)
        self.publish({"type": "estop", **result})
        return result
