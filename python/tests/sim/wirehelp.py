"""Frames by hand, for talking to the simulator with plain pyserial (no nurimc client code)."""

from __future__ import annotations

import time
from typing import Protocol

MODES = {
    "position_speed": 0x01, "accel_position": 0x02, "accel_speed": 0x03, "position_gains": 0x04,
    "speed_gains": 0x05, "set_id": 0x06, "set_baud": 0x07, "set_response_time": 0x08,
    "set_rated_speed": 0x09, "set_resolution": 0x0A, "set_ratio": 0x0B, "set_control": 0x0C,
    "set_position_mode": 0x0D, "set_direction": 0x0E, "reset_position": 0x0F, "factory_reset": 0x10,
}  # fmt: skip
ANSWER_SIZE = {0xA0: 2, 0xA1: 8, 0xA2: 8, 0xA3: 6, 0xA4: 6, 0xA5: 3, 0xA6: 4, 0xA7: 4, 0xA8: 4, 0xA9: 3,
               0xAA: 3, 0xAB: 3, 0xCD: 3}  # fmt: skip


class Port(Protocol):
    """What these helpers need of a port: pyserial's Serial, or the fake-clock port."""

    timeout: float | None

    def write(self, data: bytes, /) -> int | None: ...
    def read(self, size: int = 1, /) -> bytes: ...
    def reset_input_buffer(self) -> None: ...


def frame(ident: int, mode: int, data: bytes = b"") -> bytes:
    body = bytes([ident, len(data) + 2])
    check = ~(sum(body) + mode + sum(data)) & 0xFF
    return b"\xff\xfe" + body + bytes([check, mode]) + data


def u16(value: int) -> bytes:
    return value.to_bytes(2, "big")


def command(port: Port, ident: int, name: str, data: bytes = b"") -> None:
    port.write(frame(ident, MODES[name], data))


def parse_answer(raw: bytes, ident: int, request_mode: int) -> bytes | None:
    """The data of a valid answer frame to `request_mode` from `ident`, or None."""
    size = ANSWER_SIZE[request_mode]
    if len(raw) != size + 4 or raw[:2] != b"\xff\xfe" or raw[2] != ident or raw[3] != size:
        return None
    if raw[5] != (request_mode + 0x30) & 0xFF or raw[4] != ~(sum(raw[2:4]) + sum(raw[5:])) & 0xFF:
        return None
    return raw[6:]


def ask(port: Port, ident: int, mode: int, patience: float = 1.0) -> bytes | None:
    """Send a request, return the answer's data. Retries while the controller is busy (EEPROM)."""
    size = ANSWER_SIZE[mode] + 4
    deadline = time.monotonic() + patience
    old = port.timeout
    port.timeout = 0.1
    try:
        while True:
            port.reset_input_buffer()
            port.write(frame(ident, mode))
            answer = parse_answer(port.read(size), ident, mode)
            if answer is not None or time.monotonic() > deadline:
                return answer
    finally:
        port.timeout = old


def silent(port: Port, ident: int, mode: int, wait: float = 0.15) -> bool:
    """True if nothing at all comes back to a request within `wait`."""
    port.reset_input_buffer()
    port.write(frame(ident, mode))
    old = port.timeout
    port.timeout = wait
    try:
        return port.read(64) == b""
    finally:
        port.timeout = old


def position(port: Port, ident: int) -> float:
    """Position feedback in degrees, CCW positive."""
    data = ask(port, ident, 0xA1)
    assert data is not None, "no position feedback"
    magnitude = int.from_bytes(data[1:3], "big") / 100
    return -magnitude if data[0] else magnitude
