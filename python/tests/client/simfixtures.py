"""Helpers to put the library on a simulated bus."""

from __future__ import annotations

from nurimc import Bus
from nurimc.sim import FaultConfig, SimBus
from nurimc.transport import SerialTransport


def sim_bus(
    ids: dict[int, int] | list[int],
    baud: int = 9600,
    faults: FaultConfig | None = None,
    seed: int = 0,
    wire_timing: bool = False,
    retries: int = 2,
    resolution: int | None = None,
) -> tuple[SimBus, Bus]:
    """A simulated bus with controllers (ID list at `baud`, or {id: rate}) and a library Bus on it.

    `resolution` (encoder pulses) is written through the library first: the default of 4 pulses
    quantises the reported position to 22.5 deg, too coarse for motion tests."""
    sim = SimBus(faults=faults, seed=seed, wire_timing=wire_timing, eeprom_time=0.02)
    for device_id, rate in ids.items() if isinstance(ids, dict) else ((i, baud) for i in ids):
        sim.add_controller(id=device_id, baud=rate)
    port = sim.open_serial(baudrate=baud, timeout=0.1)
    # the sim's EEPROM writes take 20 ms here; a 50 ms busy window keeps settings-heavy tests quick
    bus = Bus(SerialTransport(port, "sim://", latency=0.002), retries=retries, busy_window=0.05)
    if resolution is not None:
        for controller in list(sim.controllers):
            bus.motor(controller.settings.id).set("resolution", resolution)
    return sim, bus
