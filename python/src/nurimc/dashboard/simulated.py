"""`nurimc dashboard --sim`: a simulated bus with motors at rates the page has to discover."""

from __future__ import annotations

from ..drivers.sync import Bus
from ..sim import SimBus
from ..transport import SerialTransport
from .frames import FrameTap

SIM_MOTORS = {1: 115200, 2: 115200, 3: 57600}  # ID -> rate
SIM_RESOLUTION = 1024  # the default 4 pulses would quantise positions to 22.5 degrees


def simulated_bus(tap: FrameTap, motors: dict[int, int] | None = None) -> tuple[SimBus, Bus]:
    """A SimBus with wire timing, its motors set to a fine encoder through the library (verified)."""
    sim = SimBus(wire_timing=True)
    table = SIM_MOTORS if motors is None else motors
    for device_id, rate in table.items():
        sim.add_controller(id=device_id, baud=rate)
    bus = Bus(SerialTransport(sim.open_serial(baudrate=9600), "sim://", latency=0.001), tracer=tap)
    for device_id, rate in table.items():
        bus.baudrate = rate
        bus.motor(device_id).set("resolution", SIM_RESOLUTION)
    bus.baudrate = 9600
    return sim, bus
