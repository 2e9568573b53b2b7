"""The one thread that talks to the bus: commands from the pages, and polling between them.

RS485 is half-duplex and the Bus runs one procedure at a time, so everything goes through this
thread's queue. Between commands it reads the watched motors' states as fast as the wire allows
(capped at POLL_HZ). The emergency stop jumps the queue and interrupts discovery and step runs.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from .. import config
from ..client.sync import Bus
from ..discovery import Progress, discover
from ..errors import NurimcError
from ..motor import Motor, MotorState
from ..protocol import BROADCAST_ID, FieldRangeError, SetControl
from . import commands as c
from .stepresponse import analyse

POLL_HZ = 200.0  # at most this many reads of each watched motor per second
ESTOP_VERIFY_SECONDS = 1.0  # the controllers answer again once their EEPROM write is done (50-300 ms)
ERROR_REPEAT = 1.0  # s between two reports of the same motor's read failure

Done = Callable[[Any, str | None], None]  # (result, error message)


class Interrupted(Exception):
    """The emergency stop cut a long command short."""


class BusWorker:
    def __init__(self, bus: Bus, product: str, publish: Callable[[dict[str, Any]], None]) -> None:
        self.bus = bus
        self.product = product
        self.publish = publish  # called from this thread: progress, errors, estop notices
        self.known: dict[int, int] = {}  # motor ID -> the rate it answers at
        self.watched: tuple[int, ...] = ()
        self._motors: dict[int, Motor] = {}
        self._jobs: deque[tuple[c.Command, Done]] = deque()
        self._wake = threading.Condition()
        self._stopping = False
        self._estop = threading.Event()
        self._samples: list[list[float]] = []
        self._samples_lock = threading.Lock()
        self._last_error: dict[int, float] = {}
        self.clock_origin = time.monotonic()
        self.reads = 0
        self._thread = threading.Thread(target=self._loop, name="nurimc-dashboard-bus", daemon=True)

    # -- from other threads ----------------------------------------------------------
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        with self._wake:
            self._stopping = True
            self._wake.notify()
        self._thread.join(timeout=5)

    def submit(self, command: c.Command, done: Done) -> None:
        with self._wake:
            if isinstance(command, c.EmergencyStop):
                self._estop.set()
                self._jobs.appendleft((command, done))
            else:
                self._jobs.append((command, done))
            self._wake.notify()

    def take_samples(self) -> list[list[float]]:
        """[id, t, position, speed, current] rows read since the last call."""
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
                if job is None:
                    delay = next_poll - time.monotonic()
                    if delay > 0:
                        self._wake.wait(delay)
                        continue
            if job is not None:
                self._carry_out(*job)
            else:
                next_poll = time.monotonic() + 1.0 / POLL_HZ
                self._poll()

    def _carry_out(self, command: c.Command, done: Done) -> None:
        if isinstance(command, c.EmergencyStop):
            self._estop.clear()
        try:
            done(self._execute(command), None)
        except Interrupted:
            done(None, "interrupted by the emergency stop")
        except (NurimcError, FieldRangeError, ValueError, KeyError) as error:
            text = error.args[0] if isinstance(error, KeyError) and error.args else str(error)
            done(None, str(text))
        except Exception as error:
            done(None, f"internal error: {type(error).__name__}: {error}")

    def _poll(self) -> None:
        for device_id in self.watched:
            try:
                self._sample(device_id)
            except NurimcError as error:
                now = time.monotonic()
                if now - self._last_error.get(device_id, 0.0) >= ERROR_REPEAT:
                    self._last_error[device_id] = now
                    self.publish({"type": "motor_error", "id": device_id, "message": str(error)})

    def _sample(self, device_id: int) -> MotorState:
        """Read one motor's state and queue it for the plots."""
        state = self.motor(device_id).read_state()
        self.reads += 1
        row = [device_id, round(time.monotonic() - self.clock_origin, 4), state.position, state.speed, state.current]
        with self._samples_lock:
            self._samples.append(row)
        return state

    def motor(self, device_id: int) -> Motor:
        """The motor's handle, with the bus switched to its rate."""
        rate = self.known.get(device_id)
        if rate is not None and rate != self.bus.baudrate:
            self.bus.baudrate = rate
        if device_id not in self._motors:
            self._motors[device_id] = self.bus.motor(device_id, self.product)
        return self._motors[device_id]

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
                (motor.move_by if relative else motor.move_to)(degrees, rpm=rpm, seconds=seconds)
                return {"id": device_id}
            case c.Run(device_id, rpm, ramp):
                self.motor(device_id).run(rpm, ramp)
                return {"id": device_id}
            case c.Release(device_id):
                self.motor(device_id).release()
                return {"id": device_id}
            case c.Hold(device_id):
                self.motor(device_id).hold()
                return {"id": device_id}
            case c.ReadSettings(device_id):
                return {"id": device_id, "settings": self.motor(device_id).read_settings()}
            case c.WriteSetting(device_id, name, value):
                verified = self.motor(device_id).set(name, value)  # writes, then reads back until it matches
                return {"id": device_id, "name": name, "value": verified, "verified": True}
            case c.Step():
                return self._step(command)
            case c.Backup(ids):
                return self._backup(ids)
            case c.Restore(document):
                return self._restore(document)
            case c.EmergencyStop():
                return self._emergency_stop()
        raise ValueError(f"the bus worker cannot carry out {command!r}")

    def _discover(self, rates: tuple[int, ...] | None) -> dict[str, Any]:
        def progress(event: object) -> None:
            self._check_estop()
            if isinstance(event, Progress):
                self.publish(
                    {
                        "type": "progress",
                        "rate": event.rate,
                        "index": event.rate_index,
                        "total": event.rates_total,
                        "walking_id": event.walking_id,
                        "found": [f.id for f in event.found],
                    }
                )

        self.watched = ()
        found = self.bus.run(discover(self.bus.core, rates), on_note=progress)
        for f in found:
            self.known[f.id] = f.baudrate
        return {"motors": [{"id": f.id, "baudrate": f.baudrate, "firmware": f.firmware} for f in found]}

    def _step(self, step: c.Step) -> dict[str, Any]:
        motor = self.motor(step.id)
        start = motor.read_state().device_position
        target = start + step.amplitude
        motor.move_to(target, rpm=step.rpm)  # range-checked by the library (±655.33 deg)
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
            single = {**document, "motors": [entry]}
            changed += self.bus.run(config.restore([self.motor(entry["id"]).procedures], single))
        return {"changed": changed}

    def _emergency_stop(self) -> dict[str, Any]:
        """Control off, broadcast at every rate a motor was found at, then each motor told and checked."""
        rates = sorted({*self.known.values(), self.bus.baudrate})
        for rate in rates:
            self.bus.baudrate = rate
            self.bus.send(SetControl(BROADCAST_ID, 1))
        for device_id in self.known:
            self.motor(device_id).release()  # records it in the handle: the next move turns control on again
        controls: dict[str, Any] = {}
        for device_id in self.known:  # each controller is busy writing EEPROM for a while: retry in a window
            controls[str(device_id)] = self._read_control(device_id)
        self.publish({"type": "estop", "rates": rates, "control": controls})
        return {"rates": rates, "control": controls}

    def _read_control(self, device_id: int) -> str:
        deadline = time.monotonic() + ESTOP_VERIFY_SECONDS
        while True:
            try:
                return str(self.motor(device_id).get("control"))
            except NurimcError as error:
                if time.monotonic() >= deadline:
                    return f"unknown: {error}"
                time.sleep(0.05)
