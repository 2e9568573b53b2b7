"""USB adapter latency: FTDI's latency timer holds received bytes for up to 16 ms by default.

Fix (Linux): `echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/latency_timer`, or a udev rule:
ACTION=="add", SUBSYSTEM=="usb-serial", DRIVER=="ftdi_sio", ATTR{latency_timer}="1"
"""

from __future__ import annotations

import os
from pathlib import Path

SYSFS = Path("/sys/bus/usb-serial/devices")
DEFAULT_USB_LATENCY = 0.016  # an unknown USB adapter: assume the FTDI default
LOCAL_LATENCY = 0.002  # pseudo-terminals, sockets, the in-process simulator: scheduling only


def latency_timer_ms(device: str, sysfs: Path = SYSFS) -> int | None:
    """The FTDI latency timer of a /dev/ttyUSBn device in ms, or None where /sys does not show it."""
    name = os.path.basename(os.path.realpath(device))
    try:
        return int((sysfs / name / "latency_timer").read_text().strip())
    except (OSError, ValueError):
        return None


def estimate_latency(url: str, sysfs: Path = SYSFS) -> tuple[float, str | None]:
    """(latency in seconds, a warning to show or None) for a port URL or device path."""
    if url[:6].lower() == "sim://":
        return 0.0, None  # in process: bytes are handed over when due, and a late reader still gets them
    if "://" in url:
        return LOCAL_LATENCY, None
    real = os.path.realpath(url)
    if os.path.basename(real).startswith(("ttyUSB", "ttyACM")):
        timer = latency_timer_ms(real, sysfs)
        if timer is None:
            return DEFAULT_USB_LATENCY, None
        warning = None
        if timer > 2:
            warning = (
                f"{url}: the USB adapter latency timer is {timer} ms, slowing every transaction; "
                f"fix: echo 1 | sudo tee {sysfs / os.path.basename(real) / 'latency_timer'} "
                "(see docs/troubleshooting.md)"
            )
        return timer / 1000 + 0.001, warning
    return LOCAL_LATENCY, None
