"""The bus: controllers, hosts and the wire between them, on one clock.

What the host sends is parsed once per rate that some controller listens at (garbled first
for the other rates), and each frame goes to the controllers it addresses (all of that
rate for a broadcast), found in an index by rate and ID: a request costs the same with 1
controller or 254. Physics stays per controller (a standing controller costs nothing).

The endpoints (in-process port, pseudo-terminal, TCP) take a bus and live in modules of
their own; `SimBus` in bus.py adds the methods that make them.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections import defaultdict
from collections.abc import Callable

from ..core.clock import VirtualClock
from ..protocol import BAUD_RATES, BROADCAST_ID, decode
from ..protocol.sniff import ExplainingParser, SniffedFrame
from .controller import EEPROM_TIME, Reply, SimController
from .faults import FaultConfig, FaultInjector
from .profile import SPEED_ZERO_CHOICES, SimProfile, default_profiles
from .settings import Settings, check_product
from .store import StateStore
from .wire import Garbler, Transmission, byte_time, merge

log = logging.getLogger("nurimc.sim")

TICK = 0.02  # s between background physics updates (real clock only)
LAG_SAY_EVERY = 10.0  # s: at most one "fell behind" warning this often (each one gives the count)
FEEDBACK_BYTES = 10  # a feedback frame: "a frame time" is how long one takes on the wire


class HostLink:
    """One host's end of the bus (an in-process port, a pseudo-terminal, a TCP client).

    A monitor link also hears what every other host sends, as a second adapter on the
    line would; anything it sends itself goes on the bus like any host's bytes.
    """

    def __init__(self, bus: WireModel, baud: int, monitor: bool = False) -> None:
        self.bus = bus
        self.baud = baud
        self.monitor = monitor
        self.rx = bytearray()  # bytes that reached this host and were not read yet
        self.closed = False
        # called (under the bus lock) when bytes reach rx: an endpoint sleeping in select() wakes
        # at once, even if another thread (the physics tick, another host) delivered them
        self.wake: Callable[[], None] | None = None

    def write(self, data: bytes) -> None:
        self.bus.host_write(self, data)

    def take(self, size: int | None = None) -> bytes:
        """Up to `size` (all if None) received bytes, after delivering what is due."""
        with self.bus.lock:
            self.bus.pump()
            n = len(self.rx) if size is None else min(size, len(self.rx))
            out = bytes(self.rx[:n])
            del self.rx[:n]
            return out

    def close(self) -> None:
        with self.bus.lock:
            self.closed = True
            if self in self.bus.links:
                self.bus.links.remove(self)


class WireModel:
    """The simulator's wire model: simulated controllers on one RS485 bus, the bytes in flight,
    collisions, rates and faults (the host library's protocol core is nurimc.core.buscore.BusCore).

    `clock` returns seconds (default time.monotonic). A `nurimc.core.clock.VirtualClock`
    makes the bus run on virtual time: physics follows every move of that clock, and a read
    on an in-process port that finds nothing moves the clock to the next byte due (or to the
    read's end) instead of sleeping; give the same clock to the library's Bus.
    With `wire_timing` every byte takes 10 bits / baud on the wire.
    `profiles` (default: spec/profiles.json) give each product's factory gains and speed-0
    rule; `speed_zero` ("ignore" or "stop") overrides that rule for every controller.
    """

    def __init__(
        self,
        wire_timing: bool = False,
        faults: FaultConfig | None = None,
        state_dir: str | os.PathLike[str] | None = None,
        seed: int = 0,
        clock: Callable[[], float] | None = None,
        eeprom_time: float = EEPROM_TIME,
        speed_zero: str | None = None,
        profiles: dict[str, SimProfile] | None = None,
    ) -> None:
        if speed_zero is not None and speed_zero not in SPEED_ZERO_CHOICES:
            raise ValueError(f"speed_zero {speed_zero!r}: use 'ignore' or 'stop'")
        self.wire_timing = wire_timing
        self.fault_config = faults or FaultConfig()
        self.faults = FaultInjector(self.fault_config, seed)
        self.seed = seed
        self.eeprom_time = eeprom_time
        self.speed_zero = speed_zero
        self.profiles = profiles or default_profiles()
        self._clock = clock or time.monotonic
        self._real_clock = clock is None
        #: the virtual clock this bus moves when a reader waits (None: time moves by itself)
        self.virtual: VirtualClock | None = clock if isinstance(clock, VirtualClock) else None
        self.lock = threading.RLock()
        self.changed = threading.Condition(self.lock)
        self.controllers: list[SimController] = []
        self.links: list[HostLink] = []
        self.airborne: list[Transmission] = []
        self.collisions = 0
        #: times the physics ran more than a frame time behind real time (a busy host), and the worst lag, s
        self.fell_behind = 0
        self.worst_lag = 0.0
        self._lag_said = -LAG_SAY_EVERY
        #: where "fell behind" is said (`nurimc sim`: stderr); None: counted only, logged at debug
        self.say_lag: Callable[[str], None] | None = None
        self.rejected: dict[int, int] = defaultdict(int)  # bytes per rate that were no frame
        # one per rate a controller listens at and product line spoken there (spec/lines.json)
        self._parsers: dict[tuple[int, str], ExplainingParser] = {}
        self._index: dict[int, dict[int, list[SimController]]] | None = None  # rate -> ID -> controllers
        self._garbler = Garbler(seed + 0x6A5)
        self._store = StateStore(state_dir) if state_dir is not None else None
        self._host_free_at = 0.0
        self._uart_free: dict[int, float] = {}  # per controller slot: when its last answer ends
        self._ticker: threading.Thread | None = None
        self._closing = threading.Event()
        if self.virtual is not None:
            self.virtual.on_advance(self._follow)

    # --- building ---------------------------------------------------------------------------
    def now(self) -> float:
        return self._clock()

    def add_controller(self, id: int = 0, baud: int = 9600, product: str = "mc") -> SimController:  # noqa: A002
        """Add a controller. With a state directory, a stored controller in this slot keeps its
        stored settings (its ID and rate may have been changed over the wire)."""
        if not isinstance(id, int) or not 0 <= id <= 0xFE:
            raise ValueError(f"controller ID {id!r} is out of range; use 0..254")
        if baud not in BAUD_RATES:
            raise ValueError(
                f"{baud} bps is not a rate these controllers support; use one of "
                + ", ".join(str(r) for r in BAUD_RATES)
            )
        check_product(product)
        with self.lock:
            slot = len(self.controllers)
            if slot >= 254:
                raise ValueError("a bus holds at most 254 controllers")
            profile = self.profiles[product]
            record = self._store.slot(slot) if self._store is not None else None
            if record is not None and record.get("product") == product:
                settings = Settings.from_dict(record["settings"], product, profile.factory_defaults)
            else:
                settings = Settings.factory(product, profile.factory_defaults)
                settings.id = id
                settings.baud_index = BAUD_RATES.index(baud)
            controller = SimController(
                settings,
                product,
                slot,
                on_settings_changed=self._settings_changed,
                eeprom_time=self.eeprom_time,
                speed_zero=self.speed_zero or profile.speed_zero,
                factory_defaults=profile.factory_defaults,
            )
            controller.restored = record is not None and record.get("product") == product
            if profile.plant is not None:
                controller.set_plant(profile.plant)
            controller.advance_to(self.now())
            settings.on_address_change(self._forget_index)
            self.controllers.append(controller)
            self._forget_index()
            self._settings_changed()
            return controller

    def _forget_index(self) -> None:
        self._index = None

    def _settings_changed(self) -> None:
        if self._store is not None:
            self._store.save([{"product": c.product, "settings": c.settings.to_dict()} for c in self.controllers])

    def _listeners(self) -> dict[int, dict[int, list[SimController]]]:
        if self._index is None:
            index: dict[int, dict[int, list[SimController]]] = {}
            for c in self.controllers:
                index.setdefault(c.baud, {}).setdefault(c.id, []).append(c)
            self._index = index
        return self._index

    def controller(self, id: int) -> SimController:  # noqa: A002
        """The first controller currently at `id` (KeyError if none)."""
        for c in self.controllers:
            if c.id == id:
                return c
        raise KeyError(f"no simulated controller has ID {id}")

    # --- hosts ------------------------------------------------------------------------------
    def open_link(self, baud: int, monitor: bool = False) -> HostLink:
        with self.lock:
            link = HostLink(self, baud, monitor)
            self.links.append(link)
        self._start_ticker()
        return link

    # --- the wire ---------------------------------------------------------------------------
    def host_write(self, link: HostLink, data: bytes) -> None:
        """The host sends `data` at its link's rate; controllers hear it and may answer."""
        if not data:
            return
        with self.lock:
            now = self.now()
            self.pump(now)
            if self.fault_config.echo:
                link.rx += data
            arrival = now
            if self.wire_timing:
                start = max(now, self._host_free_at)
                arrival = start + len(data) * byte_time(link.baud)
                self._host_free_at = arrival
            heard = self.faults.corrupt(bytes(data), noise=False)
            for other in self.links:
                if other.monitor and other is not link:
                    self._receive(other, heard, link.baud)
            explain = log.isEnabledFor(logging.DEBUG)
            listeners = self._listeners()
            if explain and link.baud not in listeners:
                rates = ", ".join(str(r) for r in sorted(listeners)) or "none"
                log.debug(
                    "host sent %d byte(s) at %d bps; no controller listens at that rate (controllers at %s): %s",
                    len(data),
                    link.baud,
                    rates,
                    bytes(data).hex(" "),
                )
            for rate in list(listeners):
                chunk = heard if rate == link.baud else self._garbler.garble(heard, link.baud, rate)
                self._hear(rate, chunk, arrival, explain and rate == link.baud)
            self.changed.notify_all()

    def _hear(self, rate: int, chunk: bytes, arrival: float, explain: bool) -> None:
        """The controllers at `rate` hear `chunk`: parsed once per product line spoken at that
        rate (a mode byte means another message in each line), each frame to whom it addresses."""
        lines = sorted(self._lines_at(rate))
        for line in lines:
            self._hear_line(rate, line, chunk, arrival, explain, len(lines) > 1)
            if self._index is None and rate not in self._listeners():
                return  # nobody listens at this rate any more

    def _hear_line(self, rate: int, line: str, chunk: bytes, arrival: float, explain: bool, mixed: bool) -> None:
        """One line's reading of the bytes at `rate`. With several lines at a rate, -v explains a
        frame in the terms of the line of the controller it addresses (the others' readings of
        the same bytes are not what any controller took)."""
        parser = self._parsers.get((rate, line))
        if parser is None:
            parser = self._parsers[(rate, line)] = ExplainingParser(line)
        where = f"@{rate} ({line})" if mixed or line != "mc" else f"@{rate}"

        def speaks(device_id: int | None) -> bool:
            """Does a controller of this line have this ID here (or is it for all, or unknown)?"""
            if not mixed or device_id == BROADCAST_ID:
                return True
            if device_id is None:  # bytes outside a frame: in one line's terms, part of another's frame
                return False
            group = self._listeners().get(rate, {}).get(device_id, ())
            return any(c.line == line for c in group) or (not group and line == min(self._lines_at(rate)))

        for event in parser.feed(chunk):
            if not isinstance(event, SniffedFrame):
                self.rejected[rate] += len(event.raw)
                if explain and speaks(event.id):
                    log.debug("%s not taken: %s: %s", where, event.reason, event.raw.hex(" "))
                continue
            message = event.message
            if explain and speaks(message.id):
                log.debug("host %s -> %s  [%s]", where, message, event.raw.hex(" "))
            by_id = self._listeners().get(rate, {})
            if message.id == BROADCAST_ID:
                targets = [c for group in by_id.values() for c in group]
            else:
                targets = list(by_id.get(message.id, ()))
                if not targets and explain and speaks(message.id):
                    elsewhere = sorted(r for r, ids in self._listeners().items() if message.id in ids)
                    log.debug(
                        "%s not taken: no controller has ID %d at this rate%s",
                        where,
                        message.id,
                        f" (wrong rate: ID {message.id} listens at {', '.join(map(str, elsewhere))} bps)"
                        if elsewhere
                        else "",
                    )
            for controller in targets:
                if controller.line != line:
                    continue  # it reads these bytes with its own line's table (another parser)
                if controller.baud != rate:
                    continue  # it moved to another rate earlier in this frame's broadcast
                reply = controller.take(message, arrival)
                if reply is not None:
                    self._send(reply)
            if self._index is None and rate not in self._listeners():
                parser.clear()  # nobody listens at this rate any more
                return

    def _lines_at(self, rate: int) -> set[str]:
        return {c.line for group in self._listeners().get(rate, {}).values() for c in group} or {"mc"}

    def _send(self, reply: Reply) -> None:
        delay = self.faults.answer_delay()
        if delay is None:
            log.debug("id %d answer lost (miss fault)", reply.controller.id)
            return
        # one UART per controller: its answers leave in the order they were asked for, never
        # overlapping (a late answer holds back the ones after it, as on a real controller)
        start = max(reply.start + delay, self._uart_free.get(reply.controller.slot, 0.0))
        frame = reply.frame * 2 if self.faults.duplicate() else reply.frame
        tx = Transmission(start, reply.baud, bytearray(frame), [reply.controller.id])
        self._uart_free[reply.controller.slot] = tx.end
        if log.isEnabledFor(logging.DEBUG):
            answer = decode(reply.frame, line=reply.controller.line)
            log.debug("id %d <- %s  [%s]", reply.controller.id, answer, reply.frame.hex(" "))
        merged = True
        while merged:
            merged = False
            for other in self.airborne:
                if other.delivered == 0 and other.overlaps(tx):
                    self.airborne.remove(other)
                    tx = merge(other, tx)
                    merged = True
                    break
        self.airborne.append(tx)
        self.airborne.sort(key=lambda t: t.start)

    def pump(self, now: float | None = None) -> None:
        """Hand every byte that has arrived by `now` to the hosts."""
        with self.lock:
            if not self.airborne:
                return
            if now is None:
                now = self.now()
            done = []
            for tx in self.airborne:
                if now < tx.start:
                    break
                if self.wire_timing:
                    due = min(len(tx.data), int((now - tx.start) / tx.byte_time + 1e-9))
                else:
                    due = len(tx.data)
                if due > tx.delivered:
                    chunk = bytes(tx.data[tx.delivered : due])
                    if tx.delivered == 0 and tx.collided:
                        self.collisions += 1
                        log.debug("collision: ids %s answered at once; the host reads %s", tx.sources, tx.data.hex(" "))
                    tx.delivered = due
                    for link in self.links:
                        self._receive(link, chunk, tx.baud)
                if tx.delivered == len(tx.data):
                    done.append(tx)
            for tx in done:
                self.airborne.remove(tx)
            if done:
                self.changed.notify_all()

    def _receive(self, link: HostLink, chunk: bytes, baud: int) -> None:
        if link.baud != baud:
            chunk = self._garbler.garble(chunk, baud, link.baud)
        link.rx += self.faults.corrupt(chunk, noise=True)
        if link.wake is not None:
            link.wake()

    def next_delivery(self) -> float | None:
        """Bus time of the next byte due at the hosts, or None if nothing is on the way."""
        with self.lock:
            if not self.airborne:
                return None
            if self.wire_timing:
                return min(tx.start + (tx.delivered + 1) * tx.byte_time for tx in self.airborne)
            return self.airborne[0].start

    def wait_hint(self, cap: float = 0.05) -> float:
        """Seconds a reader may sleep before something can be delivered (capped)."""
        due = self.next_delivery()
        wait = cap if due is None else max(0.0, min(cap, due - self.now()))
        if not self._real_clock:
            wait = min(wait, 0.001)  # a fake clock may jump at any moment
        return wait

    # --- physics in the background ------------------------------------------------------------
    def advance(self, now: float | None = None) -> None:
        """Step the physics of every moving controller up to `now` (the bus time by default).

        A standing controller (static servo) is skipped: nothing about it changes but its clock,
        and it jumps over the gap in O(1) when a frame next reaches it (take() advances it first).
        So the background tick costs nothing per idle controller and does not slow the polling
        of one controller on a large bus (benchmarks/sim_realtime.py)."""
        with self.lock:
            now = self.now() if now is None else now
            for c in self.controllers:
                if not c.servo.static:
                    c.advance_to(now)
            self.pump(now)

    def _follow(self, now: float) -> None:
        if not self._closing.is_set():
            self.advance(now)

    def wait_virtually(self, until: float | None) -> bool:
        """On virtual time: move the clock to the next byte due for the hosts, or to `until`
        if that comes first (None: no limit). False when there is nothing to wait for (time
        stands at `until`, or nothing is on the way and no limit was given)."""
        assert self.virtual is not None
        with self.lock:
            now = self.now()
            due = self.next_delivery()
            target = until if due is None else (due if until is None else min(due, until))
            if target is None or target <= now:
                if due is not None and due <= now:  # due now (rounding): nudge time past it
                    self.virtual.advance_to(now + 1e-9)
                    return True
                return False
            self.virtual.advance_to(target)
            return True

    def _start_ticker(self) -> None:
        if not self._real_clock or self._ticker is not None:
            return
        self._ticker = threading.Thread(target=self._tick, name="nurimc-sim-physics", daemon=True)
        self._ticker.start()

    def _tick(self) -> None:
        due = self.now() + TICK
        while not self._closing.wait(max(0.0, due - self.now())):
            self.advance()
            now = self.now()
            self.note_lag(now - due)
            due = max(due + TICK, now)  # far behind: carry on from now rather than race to catch up

    def frame_time(self) -> float:
        """How long a feedback frame takes at the slowest rate a controller listens at, s."""
        rates = [c.baud for c in self.controllers] or [max(BAUD_RATES)]
        return FEEDBACK_BYTES * byte_time(min(rates))

    def note_lag(self, lag: float) -> None:
        """The physics caught up `lag` seconds after it was due: more than a frame time counts as
        falling behind real time (answers and motion come late), said on stderr now and then."""
        frame = self.frame_time()
        if lag <= frame:
            return
        self.fell_behind += 1
        self.worst_lag = max(self.worst_lag, lag)
        now = self.now()
        text = (
            f"simulator fell behind real time by {lag * 1000:.1f} ms (more than a frame time, {frame * 1000:.1f} ms; "
            f"{self.fell_behind} time(s) so far): the host is busy, so answers and motion come late; "
            "give it a quieter host or fewer controllers"
        )
        log.debug("%s", text)
        if self.say_lag is not None and now - self._lag_said >= LAG_SAY_EVERY:
            self._lag_said = now
            self.say_lag(text)

    def close(self) -> None:
        """Stop the background physics (servers are stopped with their own stop())."""
        self._closing.set()
        if self._ticker is not None and self._ticker is not threading.current_thread():
            self._ticker.join(timeout=1)
        with self.lock:
            for link in list(self.links):
                link.close()
            if self._store is not None:
                self._store.close()


def describe(bus: WireModel) -> list[str]:
    """One line per controller, for startup output."""
    return [
        f"id {c.id} @ {c.baud} bps ({c.product}"
        + (f", {c.line} table)" if c.line not in (c.product, "mc") else ")")
        + ("" if c.servo.plant.is_default() else f" plant {c.servo.plant.describe()}")
        for c in bus.controllers
    ]


__all__ = ["WireModel", "HostLink", "describe"]
