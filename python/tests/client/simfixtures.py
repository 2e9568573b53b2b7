"""The one way tests put the library on a simulated bus: in process, on virtual time.

`sim_bus` builds a SimBus and a library Bus that share one VirtualClock: a read that finds
nothing moves the clock to the simulator's next byte instead of sleeping, and `clock.sleep`
lets the physics run. Tests are then fast and the same on a loaded host as on an idle one.
`clock=REAL_CLOCK` gives real time (for the few marked `realtime` end-to-end tests).
The pytest fixture `make_sim_bus` (tests/conftest.py) closes what it built.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from nurimc import Bus
from nurimc.core.clock import REAL_CLOCK, Clock, RealClock, VirtualClock
from nurimc.sim import FaultConfig, SimBus
from nurimc.transport import SerialTransport


def virtual_sim(clock: Clock | None = None, **sim_options: Any) -> SimBus:
    """A SimBus on `clock` (a new VirtualClock by default; REAL_CLOCK: real time)."""
    clock = VirtualClock() if clock is None else clock
    return SimBus(clock=None if isinstance(clock, RealClock) else clock, **sim_options)  # type: ignore[arg-type]


def bus_on(sim: SimBus, baud: int = 9600, **bus_options: Any) -> Bus:
    """A library Bus on an in-process port of `sim`, on the sim's clock."""
    port = sim.open_serial(baudrate=baud, timeout=0.1)
    clock = sim.virtual or REAL_CLOCK
    return Bus(SerialTransport(port, "sim://", latency=0.002), clock=clock, **bus_options)


def sim_bus(
    ids: dict[int, int] | list[int],
    baud: int = 9600,
    faults: FaultConfig | None = None,
    seed: int = 0,
    wire_timing: bool = False,
    retries: int = 2,
    resolution: int | None = None,
    clock: Clock | None = None,
    eeprom_time: float = 0.02,
    **bus_options: Any,
) -> tuple[SimBus, Bus]:
    """A simulated bus with controllers (ID list at `baud`, or {id: rate}) and a library Bus on it.

    `resolution` (encoder pulses) is written through the library first: the default of 4 pulses
    quantises the reported position to 22.5 deg, too coarse for motion tests."""
    sim = virtual_sim(clock, faults=faults, seed=seed, wire_timing=wire_timing, eeprom_time=eeprom_time)
    for device_id, rate in ids.items() if isinstance(ids, dict) else ((i, baud) for i in ids):
        sim.add_controller(id=device_id, baud=rate)
    # the sim's EEPROM writes take 20 ms here; a 50 ms busy window keeps settings-heavy tests quick
    bus_options.setdefault("busy_window", 0.05)
    bus = bus_on(sim, baud, retries=retries, **bus_options)
    if resolution is not None:
        for controller in list(sim.controllers):
            bus.motor(controller.settings.id).set("resolution", resolution)
    return sim, bus


def wait_until(bus: Bus, check: Callable[[], bool], timeout: float = 5.0, step: float = 0.02) -> bool:
    """Poll `check` on the bus's clock (virtual time moves; nothing sleeps for real)."""
    end = bus.clock.now() + timeout
    while bus.clock.now() < end:
        if check():
            return True
        bus.clock.sleep(step)
    return False


__all__ = ["REAL_CLOCK", "VirtualClock", "bus_on", "sim_bus", "virtual_sim", "wait_until"]
