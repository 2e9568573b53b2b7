"""Simulated MC / BLMC-H controllers on a simulated RS485 bus.

>>> from nurimc.sim import SimBus
>>> bus = SimBus()
>>> _ = bus.add_controller(id=0, baud=9600, product="mc")
>>> port = bus.open_serial(baudrate=9600, timeout=0.5)
>>> _ = port.write(bytes.fromhex("FF FE 00 02 5D A0"))  # ping ID 0
>>> port.read(6).hex(" ")
'ff fe 00 02 2d d0'
>>> port.close(); bus.close()
"""

from __future__ import annotations

import serial

from .bus import HostLink, SimBus
from .controller import EEPROM_TIME, SimController
from .faults import FaultConfig
from .settings import Settings

if "nurimc.sim.urlhandler" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("nurimc.sim.urlhandler")

__all__ = ["EEPROM_TIME", "FaultConfig", "HostLink", "Settings", "SimBus", "SimController"]
