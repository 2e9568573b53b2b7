"""The one thread that talks to the bus: commands from the pages, and polling between them.

RS485 is half-duplex and the Bus runs one procedure at a time, so everything goes through this
thread's queue. Between commands it reads the watched motors' states as fast as the wire allows
(capped at POLL_HZ).

The emergency stop wins over everything sent before it: submitting it bumps the generation,
answers every queued command of every page with "cancelled" without touching the bus,
interrupts discovery and step runs, and goes first. A command that names an older generation
(a page that had not yet heard of the stop) is refused, so nothing from before the stop can
move a motor after it.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .. import config
from ..client.sync import Bus
from ..discovery import Found, Progress, discover
from ..errors import ControllerBusy, NurimcError
from ..motor import Motor, MotorState
from ..protocol import BROADCAST_ID, FieldRangeError, ResetPosition, SetControl
from ..protocol.host import PROFILES
from . import commands as c
from .stepresponse import analyse

POLL_HZ = 200.0  # at most this many reads of each watched motor per second
ESTOP_VERIFY_SECONDS = 2.0  # the controllers answer again once their EEPROM write is done (50-300 ms)
ERROR_REPEAT = 1.0  # s between two reports of the same motor's read failure
MAX_PENDING = 256  # commands one page may have waiting for the bus; more get "busy, try again"
CANCELLED = "cancelled by the emergency stop (it was sent before the stop; nothing was done)"

Done = Callable[[Any, str | None], None]  # (result, error message)


class Interrupted(Exception):
    """The emergency stop cut a long command short."""


@dataclass
class Job:
    command: c.Command
    done: Done
    owner: object  # the page (connection) that sent it, for its pending count
    generation: int
    extra: list[Done] = field(default_factory=list)  # further pages waiting on the same emergency stop


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
        self.publish = publish  # called from this thread: progress, errors, estop notices
        self.motors: dict[int, KnownMotor] = {}  # kept for every page, new tabs and reloads
        self.watched: tuple[int, ...] = ()
        self.generation = 0  # bumped by every emergency stop
        self._handles: dict[int, Motor] = {}
        self._jobs: deque[Job] = deque()
        self._pending: dict[object, int] = {}
        self._wake = threading.Condition()
        self._stopping = False
        self._estop = threading.Event()
        self._samples: list[list[float]] = []
        self._samples_lock = threading.Lock()
        self._last_error: dict[int, float] = {}
        self._busy_until: dict[int, tuple[float, str]] = {}  # motor -> (end of its EEPROM busy window, why)
        self.busy_window = PROFILES[product].busy_window if product in PROFILES else 0.3
        self.clock_origin = time.monotonic()
        self.reads = 0
        self._thread = threading.Thread(target=self._loop, name="nurimc-dashboard-bus", daemon=True)

    @property
    def known(self) -> dict[int, int]:
        """Motor ID -> the rate it answers at."""
        return {m.id: m.baudrate for m in self.motors.values()}

    def motor_list(self) -> list[dict[str, Any]]:
        return [m.as_dict() for m in sorted(self.motors.values(), key=lambda m: m.id)]

    # -- from other threads ----------------------------------------------------------
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        with self._wake:
            self._stopping = True
            self._wake.notify()
        self._thread.join(timeout=5)

    def submit(self, command: c.Command, done: Done, owner: object = None, generation: int | None = None) -> None:
        """Queue a command; `done` is always called exactly once, from any thread."""
        cancelled: list[Done] = []
        refusal: str | None = None
        with self._wake:
            if isinstance(command, c.EmergencyStop):
                self._estop.set()
                self.generation += 1
                queued = next((j for j in self._jobs if isinstance(j.command, c.EmergencyStop)), None)
                for job in self._jobs:
                    if job is not queued:
                        cancelled.append(job.done)
                        self._finished(job.owner)
                self._jobs.clear()
                if queued is not None:  # one stop already waiting: this page waits on it too
                    queued.extra.append(done)
                    self._jobs.append(queued)
                else:
                    self._jobs.append(Job(command, done, owner, self.generation))
                self._wake.notify()
            elif generation is not None and generation < self.generation:
                refusal = f"refused: sent before emergency stop #{self.generation}; press the button again"
            elif self._pending.get(owner, 0) >= MAX_PENDING:
                refusal = f"busy: {MAX_PENDING} commands from this page are waiting for the bus; try again shortly"
            else:
                self._pending[owner] = self._pending.get(owner, 0) + 1
                self._jobs.append(Job(command, done, owner, self.generation))
                self._wake.notify()
        for cancel in cancelled:
            cancel(None, CANCELLED)
        if refusal is not None:
            done(None, refusal)

    def forget(self, owner: object) -> None:
        """A page went away: its queued commands are dropped, not carried out for no one."""
        with self._wake:
            gone = [j for j in self._jobs if j.owner is owner and not isinstance(j.command, c.EmergencyStop)]
            gone_ids = {id(j) for j in gone}
            self._jobs = deque(j for j in self._jobs if id(j) not in gone_ids)
            self._pending.pop(owner, None)
        for job in gone:
            job.done(None, "dropped: the page closed")

    def _finished(self, owner: object) -> None:  # with self._wake held
        left = self._pending.get(owner, 0) - 1
        if left > 0:
            self._pending[owner] = left
        else:
            self._pending.pop(owner, None)

    def take_samples(self) -> list[list[float]]:
        """[id, t, position, speed, current, device_position] rows read since the last call."""
        with self._samples_lock:
            out, self._samples = self._samples, []
            return out

    # -- the thread ------------------------------------------------------------------
    def _loop(self) -> None:
        next_poll = 0.0
        while True:
            with self._wake:
                while not self._stopping and not self._jobs and not self.watched:
                    self._wake.wait()
                if self._stopping:
                    return
                job = self._jobs.popleft() if self._jobs else None
                if job is not None and not isinstance(job.command, c.EmergencyStop):
                    self._finished(job.owner)
                if job is None:
                    delay = next_poll - time.monotonic()
                    if delay > 0:
                        self._wake.wait(delay)
                        continue
            if job is not None:
                self._carry_out(job)
            else:
                next_poll = time.monotonic() + 1.0 / POLL_HZ
                self._poll()

    def _carry_out(self, job: Job) -> None:
        command = job.command
        result: Any = None
        error: str | None = None
        if isinstance(command, c.EmergencyStop):
            self._estop.clear()
        elif job.generation < self.generation:  # a stop came in after this was queued
            error = CANCELLED
        if error is None:
            try:
                result = self._execute(command)
            except Interrupted:
                error = "interrupted by the emergency stop"
            except (NurimcError, FieldRangeError, ValueError, KeyError, ArithmeticError) as problem:
                text = problem.args[0] if isinstance(problem, KeyError) and problem.args else str(problem)
                error = str(text)
            except Exception as problem:
                error = f"internal error: {type(problem).__name__}: {problem}"
        for done in (job.done, *job.extra):
            done(result, error)

    def _poll(self) -> None:
        for device_id in self.watched:
            try:
                self._sample(device_id)
            except NurimcError as error:
                now = time.monotonic()
                busy_until, why = self._busy_until.get(device_id, (0.0, ""))
                if now < busy_until or isinstance(error, ControllerBusy):
                    text = f"ID {device_id} is busy writing its settings{why}; readings resume in a moment"
                    kind = "busy"
                else:
                    text, kind = str(error), "error"
                if now - self._last_error.get(device_id, 0.0) >= ERROR_REPEAT:
                    self._last_error[device_id] = now
                    self.publish({"type": "motor_error", "id": device_id, "message": text, "kind": kind})

    def _sample(self, device_id: int) -> MotorState:
        """Read one motor's state and queue it for the plots."""
        state = self.motor(device_id).read_state()
        self.reads += 1
        t = round(time.monotonic() - self.clock_origin, 4)
        row = [device_id, t, state.position, state.speed, state.current, state.device_position]
        with self._samples_lock:
            self._samples.append(row)
        return state

    def motor(self, device_id: int) -> Motor:
        """The motor's handle, with the bus switched to its rate."""
        known = self.motors.get(device_id)
        if known is not None and known.baudrate != self.bus.baudrate:
            self.bus.baudrate = known.baudrate
        if device_id not in self._handles:
            # the product line discovery found for the ID (nurimc.products) beats the default "mc"
            found = self.bus.core.products.get(device_id) if self.product == "mc" else None
            self._handles[device_id] = self.bus.motor(device_id, found or self.product)
        return self._handles[device_id]

    def _wrote_eeprom(self, device_id: int, why: str) -> None:
        """The controller may not answer for a while: say so instead of blaming the wiring."""
        self._busy_until[device_id] = (time.monotonic() + self.busy_window + 0.2, why)

    def _check_estop(self) -> None:
        if self._estop.is_set():
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
                return {"id": device_id}
            case c.Run(device_id, rpm, ramp):
                self._wrote_eeprom(device_id, " (control on)")
                self.motor(device_id).run(rpm, ramp)
                return {"id": device_id}
            case c.Release(device_id):
                self._wrote_eeprom(device_id, " after the release")
                self.motor(device_id).release()
                return {"id": device_id, "control": "off"}
            case c.Hold(device_id):
                self._wrote_eeprom(device_id, " (control on)")
                self.motor(device_id).hold()
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
            case c.FactoryReset(device_id):
                return self._factory_reset(device_id)
            case c.Ports():
                return {"ports": self._ports(), "current": self.port, "baudrate": self.bus.baudrate}
            case c.OpenBus(port, rate):
                return self._open_bus(port, rate)
            case c.EmergencyStop():
                return self._emergency_stop()
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
        firmware = f.firmware if f.firmware is not None else (old.firmware if old else None)
        self.motors[f.id] = KnownMotor(f.id, f.baudrate, firmware)

    def _step(self, step: c.Step) -> dict[str, Any]:
        motor = self.motor(step.id)
        start = motor.read_state().device_position
        target = round(start + step.amplitude, 2)
        if abs(target) > 655.33:
            raise ValueError(
                f"step: the target {target:.2f} deg is past the device's position range ±655.33 deg "
                f"(the motor is at {start:.2f} deg in the device's frame); use a smaller step, "
                "move back, or set zero here first"
            )
        self._wrote_eeprom(step.id, " (control on)")
        motor.move_to(target, rpm=step.rpm)
        began = time.monotonic()
        times: list[float] = [0.0]
        positions: list[float] = [start]
        while (elapsed := time.monotonic() - began) < step.duration:
            self._check_estop()
            state = self._sample(step.id)
            times.append(round(elapsed, 4))
            positions.append(state.device_position)
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
        self.bus.send(ResetPosition(device_id))
        motor.procedures.tracker.reset()
        deadline = time.monotonic() + 0.5
        while True:  # the new zero shows in the next reading
            state = motor.read_state()
            if abs(state.device_position) < 1.0 or time.monotonic() >= deadline:
                break
            time.sleep(0.02)
        return {"id": device_id, "device_position": state.device_position, "position": state.position}

    def _change_id(self, device_id: int, new_id: int) -> dict[str, Any]:
        if new_id in self.motors:
            raise ValueError(f"ID {new_id} is already taken by a known motor; pick a free ID")
        motor = self.motor(device_id)
        self._wrote_eeprom(device_id, " (new ID)")
        self.bus.run(config.change_id(self.bus.core, device_id, new_id))  # refuses a taken ID, verifies
        old = self.motors.pop(device_id, KnownMotor(device_id, self.bus.baudrate, None))
        self._handles.pop(device_id, None)
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
        if port == self.port:
            self.bus.baudrate = rate
            return {"port": port, "baudrate": rate}
        if self.port.startswith("sim"):
            raise ValueError("this console runs on the simulated bus (--sim); restart it with --port for a real port")
        new = Bus.open(port, baudrate=rate, tracer=self.tracer)  # PortError says what is wrong
        old, self.bus, self.port = self.bus, new, port
        old.close()
        self.motors.clear()
        self._handles.clear()
        self.watched = ()
        self.publish({"type": "motors", "motors": [], "generation": self.generation})
        return {"port": port, "baudrate": rate}

    def _forget_watch(self, old: int, new: int | None) -> None:
        ids = [i for i in self.watched if i != old]
        if new is not None:
            ids.append(new)
        self.watched = tuple(sorted(ids))

    def _emergency_stop(self) -> dict[str, Any]:
        """Control off, broadcast at every rate a motor was found at, then each motor told and checked.

        A controller busy writing its EEPROM (after a hold or a setting, 50-300 ms) ignores frames,
        so a broadcast can be lost on it: each motor is read back and told again until it reads
        "off" or ESTOP_VERIFY_SECONDS pass (then it is reported as not confirmed).
        """
        rates = sorted({*self.known.values(), self.bus.baudrate})
        for rate in rates:
            self.bus.baudrate = rate
            self.bus.send(SetControl(BROADCAST_ID, 1))
        for device_id in self.known:
            self._wrote_eeprom(device_id, " after the emergency stop")
            with contextlib.suppress(NurimcError):  # the broadcast went out; the read-back below tells the truth
                self.motor(device_id).release()  # records it in the handle: the next move turns control on again
        controls: dict[str, Any] = {}
        unconfirmed = set(self.known)
        deadline = time.monotonic() + ESTOP_VERIFY_SECONDS
        while unconfirmed:
            for device_id in sorted(unconfirmed):
                controls[str(device_id)] = value = self._read_control(device_id)
                if value == "off":
                    unconfirmed.discard(device_id)
                else:  # still on, or not answering yet: tell it again
                    with contextlib.suppress(NurimcError):
                        self.motor(device_id).release()
            if not unconfirmed or time.monotonic() >= deadline:
                break
            time.sleep(0.05)
        result = {"rates": rates, "control": controls, "generation": self.generation}
        self.publish({"type": "estop", **result})
        return result

    def _read_control(self, device_id: int) -> str:
        try:
            return str(self.motor(device_id).get("control"))
        except NurimcError as error:
            return f"unknown: {error}"
