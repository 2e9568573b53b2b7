"""Every setting, through a pseudo-terminal opened with plain pyserial."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from .conftest import Pty
from .wirehelp import ask, command, silent, u16

# (command, data, request mode, the answer's data)
ROUND_TRIPS = [
    ("position_gains", bytes([7, 3, 9, 40]), 0xA3, bytes([7, 3, 9, 40])),
    ("speed_gains", bytes([11, 12, 13, 20]), 0xA4, bytes([11, 12, 13, 20])),
    ("set_response_time", bytes([37]), 0xA5, bytes([37])),
    ("set_rated_speed", u16(2000), 0xA6, u16(2000)),
    ("set_resolution", u16(13), 0xA7, u16(13)),
    ("set_ratio", u16(100), 0xA8, u16(100)),
    ("set_control", bytes([1]), 0xA9, bytes([1])),
    ("set_position_mode", bytes([1]), 0xAA, bytes([1])),
    ("set_direction", bytes([1]), 0xAB, bytes([1])),
]
FACTORY = {0xA3: bytes([50, 0, 10, 50]), 0xA4: bytes([30, 10, 0, 50]), 0xA5: bytes([1]), 0xA6: u16(3000),
           0xA7: u16(4), 0xA8: u16(10), 0xA9: bytes([0]), 0xAA: bytes([0]), 0xAB: bytes([0])}  # fmt: skip


def test_ping_and_firmware(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    assert ask(port, 0, 0xA0) == b""
    assert ask(port, 0, 0xCD) == bytes([1])
    assert silent(port, 1, 0xA0)  # nobody at ID 1


def test_factory_defaults(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    for mode, expected in FACTORY.items():
        assert ask(port, 0, mode) == expected, f"request {mode:02X}"


def test_blmc_h_defaults(make_pty: Callable[..., Pty]) -> None:
    port = make_pty(product="blmc-h").open()
    assert ask(port, 0, 0xA3) == bytes([40, 0, 15, 80])
    assert ask(port, 0, 0xA4) == bytes([25, 8, 0, 80])


@pytest.mark.parametrize(("name", "data", "mode", "answer"), ROUND_TRIPS, ids=[r[0] for r in ROUND_TRIPS])
def test_setting_round_trips(make_pty: Callable[..., Pty], name: str, data: bytes, mode: int, answer: bytes) -> None:
    port = make_pty().open()
    assert ask(port, 0, mode) != answer  # it really changes
    command(port, 0, name, data)
    assert ask(port, 0, mode) == answer


def test_commands_are_never_answered(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    command(port, 0, "set_rated_speed", u16(1234))
    port.timeout = 0.2
    assert port.read(16) == b""
    assert ask(port, 0, 0xA6) == u16(1234)


def test_out_of_range_setting_is_ignored(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    command(port, 0, "set_baud", bytes([18]))  # no such rate
    command(port, 0, "position_gains", bytes([0, 0, 0, 10]))  # Kp 0 is outside 1..254
    assert ask(port, 0, 0xA3) == FACTORY[0xA3]


def test_id_change_is_immediate(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    command(port, 0, "set_id", bytes([42]))
    assert ask(port, 42, 0xA0) == b""
    assert silent(port, 0, 0xA0)


def test_baud_change_answers_only_at_new_rate(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty()
    port = pty.open(9600)
    command(port, 0, "set_baud", bytes([13]))  # 115,200 bps
    assert silent(port, 0, 0xA0, wait=0.3)
    port.baudrate = 115200
    assert ask(port, 0, 0xA0) == b""
    port.baudrate = 9600
    assert silent(port, 0, 0xA0)


def test_wrong_rate_gets_no_answer(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty([(0, 9600), (1, 57600)])
    port = pty.open(57600)
    assert ask(port, 1, 0xA0) == b""
    assert silent(port, 0, 0xA0)
    assert pty.bus.controllers[0].frames_received == 0  # it heard only garbage


def test_busy_while_writing_eeprom(make_pty: Callable[..., Pty]) -> None:
    port = make_pty(eeprom_time=0.5).open()
    command(port, 0, "set_response_time", bytes([3]))
    assert silent(port, 0, 0xA5, wait=0.1)  # still writing
    assert ask(port, 0, 0xA5, patience=2.0) == bytes([3])


def test_factory_reset_restores_defaults(make_pty: Callable[..., Pty]) -> None:
    port = make_pty().open()
    for name, data, mode, answer in ROUND_TRIPS:
        command(port, 0, name, data)
        assert ask(port, 0, mode) == answer
    command(port, 0, "set_id", bytes([9]))
    assert ask(port, 9, 0xA0) == b""
    command(port, 0xFF, "factory_reset")
    for mode, expected in FACTORY.items():
        assert ask(port, 0, mode) == expected, f"request {mode:02X}"


def test_factory_reset_restores_the_default_rate(make_pty: Callable[..., Pty]) -> None:
    pty = make_pty([(0, 115200)])
    port = pty.open(115200)
    command(port, 0, "factory_reset")
    assert silent(port, 0, 0xA0, wait=0.3)
    port.baudrate = 9600
    assert ask(port, 0, 0xA0) == b""


def test_persistence_survives_restart(make_pty: Callable[..., Pty], tmp_path: Path) -> None:
    state = tmp_path / "state"
    first = make_pty([(0, 9600), (1, 9600)], state_dir=state)
    port = first.open()
    command(port, 1, "set_rated_speed", u16(1500))
    assert ask(port, 1, 0xA6) == u16(1500)
    command(port, 0, "position_gains", bytes([99, 1, 2, 30]))
    assert ask(port, 0, 0xA3) == bytes([99, 1, 2, 30])
    command(port, 1, "set_id", bytes([7]))
    assert ask(port, 7, 0xA0) == b""
    first.close()

    second = make_pty([(0, 9600), (1, 9600)], state_dir=state)  # same command line as before
    port = second.open()
    assert ask(port, 0, 0xA3) == bytes([99, 1, 2, 30])
    assert ask(port, 7, 0xA6) == u16(1500)
    assert silent(port, 1, 0xA0)
    assert (state / "bus.json").is_file()
