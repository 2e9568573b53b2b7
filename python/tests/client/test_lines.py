"""Product lines through the library: detection by the vendor's rule, each line's API, and what a
line cannot do refused before anything is sent (docs/protocol.md, Product lines)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc import Bus, InputError
from nurimc.procedures.discovery import discover
from nurimc.procedures.products import detect_line
from nurimc.protocol import WrongLineError, line
from nurimc.sim import SimBus
from nurimc.transport import SerialTransport

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
MIXED = {1: (9600, "mc"), 7: (57600, "rsa"), 9: (115200, "sm")}


def lines_bus(controllers: dict[int, tuple[int, str]], baud: int = 19200) -> tuple[SimBus, Bus]:
    sim = SimBus(eeprom_time=0.02)
    for device_id, (rate, product) in controllers.items():
        sim.add_controller(id=device_id, baud=rate, product=product)
    port = sim.open_serial(baudrate=baud, timeout=0.1)
    return sim, Bus(SerialTransport(port, "sim://", latency=0.002), busy_window=0.05)


@pytest.fixture
def mixed() -> Iterator[tuple[SimBus, Bus]]:
    sim, bus = lines_bus(MIXED)
    yield sim, bus
    bus.close()
    sim.close()


def test_discovery_names_each_line_at_unknown_rates(mixed: tuple[SimBus, Bus]) -> None:
    _, bus = mixed
    found = bus.run(discover(bus.core))
    assert {(f.id, f.baudrate, f.line) for f in found} == {(1, 9600, "mc"), (7, 57600, "rsa"), (9, 115200, "sm")}
    assert bus.baudrate == 19200
    for f in found:  # bus.motor(id) takes the line discovery found
        assert bus.motor(f.id).procedures.line.key == f.line


def test_each_line_reads_in_its_own_terms(mixed: tuple[SimBus, Bus]) -> None:
    sim, bus = mixed
    bus.run(discover(bus.core))
    bus.baudrate = 57600
    rsa = bus.motor(7)
    assert rsa.read_state().position == 0
    settings = rsa.read_settings()
    assert "rated-speed" not in settings and "direction" not in settings and settings["ratio"] == 1.0
    assert rsa.set("ratio", 5) == 5.0
    assert sim.controller(7).settings.ratio == 50  # written with RSA's 09, read back with its A6
    bus.baudrate = 115200
    sm = bus.motor(9)
    assert set(sm.read_settings()) == {
        "speed-kp", "speed-ki", "speed-kd", "speed-rated-current", "response-time", "ratio", "control", "firmware"
    }  # fmt: skip
    assert sm.read_state().speed == 0


def test_a_speed_only_sm_refuses_position_commands_and_disputed_codes(mixed: tuple[SimBus, Bus]) -> None:
    sim, bus = mixed
    bus.baudrate = 115200
    sm = bus.motor(9, "sm")
    sent_before = bus.core.stats.requests
    with pytest.raises(InputError, match="speed-only motor: it has no position commands"):
        sm.move_to(90, rpm=30)
    with pytest.raises(InputError, match="speed-only"):
        sm.hold()
    with pytest.raises(InputError, match="two SM tables disagree"):
        sm.run(30)
    with pytest.raises(InputError, match="two SM tables disagree"):
        sm.set("speed-kp", 20)
    assert bus.core.stats.requests == sent_before  # nothing was sent
    sm_cs = bus.motor(9, "sm-cs")  # the user says which table: the C# library's
    sm_cs.run(-60, ramp_seconds=0.2)
    assert sim.controller(9).servo.ramp is not None or sim.controller(9).servo.motor.speed != 0
    sm_cs.release()
    assert sim.controller(9).settings.control == 1


def test_an_rsa_motor_builds_rsa_frames() -> None:
    sim, bus = lines_bus({7: (9600, "rsa")}, baud=9600)
    motor = bus.motor(7, "rsa")
    release = motor.make_release()
    assert release.encode()[5] == 0x0A  # RSA's control on/off (MC's 0A is resolution)
    with pytest.raises(WrongLineError, match="cannot go to a controller of the MC line"):
        line("mc").check(release)
    motor.release()
    assert sim.controller(7).settings.control == 1
    with pytest.raises(InputError, match=r"RSA line has no request_rated_speed \(the rated-speed setting\)"):
        motor.set("rated-speed", 1000)
    bus.close()
    sim.close()


@pytest.mark.parametrize(
    ("product", "named"), [("mc", "mc"), ("blmc-h", "mc"), ("rsa", "rsa"), ("sa", "rsa"), ("rsavw", "rsavw"),
                           ("sm", "sm"), ("sm-readme", "sm")],
)  # fmt: skip
def test_the_vendor_rule_and_its_limits(product: str, named: str) -> None:
    sim, bus = lines_bus({3: (9600, product)}, baud=9600)
    assert bus.run(detect_line(bus.core, 3)).line == named
    bus.close()
    sim.close()


def test_no_controller_is_unknown() -> None:
    sim, bus = lines_bus({3: (9600, "mc")}, baud=9600)
    assert bus.run(detect_line(bus.core, 4)).line == "unknown"
    bus.close()
    sim.close()


def nurimc(*args: str) -> subprocess.CompletedProcess[str]:
    url = "sim://?" + "&".join(f"motor={i}@{rate}:{product}" for i, (rate, product) in MIXED.items())
    command = [NURIMC, "--port", url, "--json", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


def test_scan_and_status_from_the_command_line() -> None:
    scan = nurimc("scan")
    assert scan.returncode == 0, scan.stderr
    assert {(f["id"], f["line"]) for f in json.loads(scan.stdout)} == {(1, "mc"), (7, "rsa"), (9, "sm")}
    for device_id, (rate, product) in MIXED.items():
        done = nurimc("--id", str(device_id), "--baud", str(rate), "status")
        assert done.returncode == 0, done.stderr
        status = json.loads(done.stdout)
        assert status["line"] == product
        assert ("rated-speed" in status["settings"]) == (product == "mc")
        assert ("position-kp" in status["settings"]) == (product != "sm")
    run = nurimc("--id", "9", "--baud", "115200", "run", "30")
    assert run.returncode == 2 and "--product sm-cs or sm-readme" in run.stderr
    written = nurimc("--id", "7", "--baud", "57600", "set", "ratio", "5")  # RSA's 09, read back with A6
    assert written.returncode == 0, written.stderr
    assert json.loads(written.stdout)["value"] == 5.0
    refused = nurimc("--id", "7", "--baud", "57600", "set", "rated-speed", "1000")
    assert refused.returncode != 0 and "RSA line has no" in refused.stderr


def test_id_changes_and_resets_go_out_in_the_motors_line() -> None:
    from nurimc.procedures import config as cfg

    sim, bus = lines_bus({7: (9600, "rsa"), 9: (9600, "sm")}, baud=9600)
    bus.run(discover(bus.core, rates=[9600]))  # 7: rsa, 9: sm (the agreed table)
    bus.run(cfg.change_id(bus.core, 7, 8))  # RSA's set ID is 06, as MC's
    assert sim.controller(8).product == "rsa"
    with pytest.raises(InputError, match="SM: its line has no set_id"):
        bus.run(cfg.change_id(bus.core, 9, 4))  # disputed: 03 (C#) or none (README)
    bus.core.products[9] = "sm-cs"  # the user says which table it speaks
    bus.run(cfg.change_id(bus.core, 9, 4))  # C# 03
    assert sim.controller(4).product == "sm"
    bus.run(cfg.factory_reset(bus.core, 8, confirm=True))  # RSA's factory reset is 0D (MC's 10)
    assert sim.controller(0).product == "rsa"
    bus.close()
    sim.close()


def test_the_bus_refuses_a_frame_that_means_something_else_to_the_motor() -> None:
    from nurimc.protocol import SetControl, WrongLineError

    sim, bus = lines_bus({7: (9600, "rsa")}, baud=9600)
    bus.run(discover(bus.core, rates=[9600]))
    with pytest.raises(WrongLineError, match=r"use RSA's own set_control \(mode 0A\)"):
        bus.send(SetControl(7, 1))  # MC's 0C: an RSA's position reset
    bus.motor(7).ping()  # a ping is the same frame in every line
    assert sim.controller(7).settings.control == 0
    bus.close()
    sim.close()


def test_decode_and_encode_from_the_command_line_in_a_line() -> None:
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([NURIMC, "--json", *args], capture_output=True, text=True, timeout=60)

    rsavw = run("decode", "--line", "rsavw", "FF FE 02 05 F2 D9 01 8C A0")  # the vendor reader's D9 layout
    assert rsavw.returncode == 0, rsavw.stderr
    (frame,) = json.loads(rsavw.stdout)["frames"]
    assert (frame["message"], frame["fields"]) == ("absolute_position", {"direction": 1, "absolute_position": 36000})
    sm = run("encode", "--line", "sm-cs", "set_id", "new_id=1")
    assert json.loads(sm.stdout)["hex"] == "fffe0003f80301"
    refused = run("encode", "--line", "sm", "set_id", "new_id=1")
    assert refused.returncode == 2 and "unknown message 'set_id' in the SM line" in refused.stderr
