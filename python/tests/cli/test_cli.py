"""Every CLI command end to end: the real `nurimc` executable against the simulator on a pseudo-terminal."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from nurimc.sim import SimBus

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def cli(*args: str, port: str | None = None, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    env.pop("NURIMC_PORT", None)
    full = [NURIMC, *(["--port", port] if port else []), *args]
    return subprocess.run(full, capture_output=True, text=True, timeout=60, env=env, input=stdin)


def ok_json(*args: str, port: str) -> object:
    proc = cli("--json", *args, port=port)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


@pytest.fixture(scope="module")
def pty() -> Iterator[tuple[SimBus, str]]:
    sim = SimBus(eeprom_time=0.02)
    for device_id in (1, 2):
        sim.add_controller(id=device_id, baud=9600)
    sim.add_controller(id=7, baud=115200)
    endpoint = sim.serve_pty()
    yield sim, endpoint.path
    endpoint.stop()
    sim.close()


def test_scan_finds_every_controller(pty) -> None:  # type: ignore[no-untyped-def]
    found = ok_json("scan", "--rates", "9600,115200", port=pty[1])
    assert sorted((f["id"], f["baud"]) for f in found) == [(1, 9600), (2, 9600), (7, 115200)]
    assert set(found[0]) == {"id", "baud", "firmware", "collision", "line", "product_guess"}
    assert {f["line"] for f in found} == {"mc"}
    table = cli("scan", "--rates", "9600", port=pty[1])
    assert table.returncode == 0 and "2 controller(s) found" in table.stdout


def test_ping_and_status(pty) -> None:  # type: ignore[no-untyped-def]
    assert ok_json("--id", "1", "ping", port=pty[1])["ok"] is True  # type: ignore[index]
    status = ok_json("--id", "1", "status", port=pty[1])
    assert set(status) == {"id", "baud", "line", "product", "state", "settings"}  # type: ignore[arg-type]
    assert status["line"] == "mc"  # type: ignore[index]
    assert status["settings"]["rated-speed"] == 3000  # type: ignore[index]
    assert set(status["state"]) == {"position_deg", "device_position_deg", "speed_rpm", "current_a", "direction"}  # type: ignore[index]
    text = cli("--id", "7", "--baud", "115200", "status", port=pty[1])
    assert text.returncode == 0 and "rated-speed" in text.stdout and "3000" in text.stdout


def test_set_get_round_trip_in_physical_units(pty) -> None:  # type: ignore[no-untyped-def]
    for name, value, expected in [
        ("ratio", "12.5", 12.5),
        ("response-time", "300us", 300),
        ("direction", "cw", "cw"),
        ("resolution", "1000", 1000),
    ]:
        written = ok_json("--id", "2", "set", name, value, port=pty[1])
        assert written["value"] == expected and written["verified"] is True  # type: ignore[index]
        assert ok_json("--id", "2", "get", name, port=pty[1])["value"] == expected  # type: ignore[index]
    assert cli("--id", "2", "set", "direction", "ccw", port=pty[1]).returncode == 0


def test_move_then_watch_shows_the_motion(pty) -> None:  # type: ignore[no-untyped-def]
    assert ok_json("--id", "1", "set", "resolution", "1000", port=pty[1])
    assert cli("--id", "1", "move", "45", "--rpm", "300", port=pty[1]).returncode == 0
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        readings = ok_json("--id", "1", "watch", "--count", "2", "--interval", "0.05", port=pty[1])
        if abs(readings[-1]["position_deg"] - 45) < 0.5:  # type: ignore[index]
            break
    assert abs(readings[-1]["position_deg"] - 45) < 0.5  # type: ignore[index]
    assert cli("--id", "1", "move", "--by", "--seconds", "0.3", "--", "-15", port=pty[1]).returncode == 0
    assert cli("--id", "1", "run", "--ramp", "0.2", "--", "-60", port=pty[1]).returncode == 0
    assert cli("--id", "1", "release", port=pty[1]).returncode == 0
    assert ok_json("--id", "1", "get", "control", port=pty[1])["value"] == "off"  # type: ignore[index]
    assert cli("--id", "1", "hold", port=pty[1]).returncode == 0
    assert ok_json("--id", "1", "get", "control", port=pty[1])["value"] == "on"  # type: ignore[index]


def test_backup_restore_and_factory_reset(pty, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    backup = tmp_path / "bus.json"
    assert cli("--id", "1,2", "backup", str(backup), port=pty[1]).returncode == 0
    assert cli("--id", "2", "set", "position-kp", "99", port=pty[1]).returncode == 0
    restored = ok_json("restore", str(backup), port=pty[1])
    assert any("position-kp: 99" in line for line in restored["changed"])  # type: ignore[index]
    refused = cli("--id", "2", "factory-reset", port=pty[1], stdin="")
    assert refused.returncode == 2 and "--yes" in refused.stderr


def test_set_id_and_baud_follow_the_safety_rules(pty) -> None:  # type: ignore[no-untyped-def]
    taken = cli("--id", "2", "set", "id", "1", port=pty[1])
    assert taken.returncode == 1 and "already answers" in taken.stderr
    assert cli("--id", "2", "set", "id", "5", port=pty[1]).returncode == 0
    assert cli("--id", "5", "set", "baud", "57600", port=pty[1]).returncode == 0
    assert ok_json("--id", "5", "--baud", "57600", "ping", port=pty[1])["ok"] is True  # type: ignore[index]
    assert cli("--id", "5", "--baud", "57600", "set", "baud", "9600", port=pty[1]).returncode == 0
    assert cli("--id", "5", "set", "id", "2", port=pty[1]).returncode == 0


def test_errors_are_one_line_with_exit_codes(pty) -> None:  # type: ignore[no-untyped-def]
    missing = cli("--id", "1", "ping", port="/dev/nurimc-no-such-port")
    assert missing.returncode == 1 and "not found" in missing.stderr and "Traceback" not in missing.stderr
    wrong_baud = cli("--id", "1", "--baud", "57600", "ping", port=pty[1])
    assert wrong_baud.returncode == 1 and "no answer" in wrong_baud.stderr and "baud" in wrong_baud.stderr
    bad_value = cli("--id", "1", "set", "ratio", "0", port=pty[1])
    assert bad_value.returncode == 2 and "0.1:1..6553.3:1" in bad_value.stderr
    unknown = cli("--id", "1", "get", "colour", port=pty[1])
    assert unknown.returncode == 2 and "position-kp" in unknown.stderr
    no_port = cli("--id", "1", "ping")
    assert no_port.returncode == 2 and "NURIMC_PORT" in no_port.stderr
    bad_rate = cli("--baud", "9601", "--id", "1", "ping", port=pty[1])
    assert bad_rate.returncode == 2 and "115200" in bad_rate.stderr
    for proc in (missing, wrong_baud, bad_value, unknown, no_port, bad_rate):
        assert "Traceback" not in proc.stderr


def test_decode_encode_sniff_replay(pty, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    decoded = json.loads(cli("--json", "decode", "FF FE 00 07 76 01 00 46 50 03 E8").stdout)
    assert decoded["frames"][0]["physical"] == {"direction": "ccw", "position": 180.0, "speed": 100.0}
    broken = cli("decode", "FF FE 00 02 5D A1")
    assert broken.returncode == 2 and "checksum" in broken.stdout
    printed = cli("--json", "decode", "-", stdin="FF FE 00 03 EC 0F 01")
    assert "size" in printed.stdout  # erratum 2 as printed
    assert (
        cli("encode", "position_speed", "direction=0", "position=180deg", "speed=100rpm").stdout.strip()
        == "FF FE 00 07 76 01 00 46 50 03 E8"
    )
    bad = cli("encode", "position_speed", "direction=0", "position=180deg", "speed=0")
    assert bad.returncode == 2 and "speed" in bad.stderr
    sniffed = ok_json("sniff", "--duration", "0.3", port=pty[1])
    assert sniffed["frames"] == []  # type: ignore[index]
    from nurimc import Bus

    log = tmp_path / "traffic.log"
    with Bus.open(pty[1], log_path=str(log)) as bus:
        bus.motor(1).read_state()
    replayed = ok_json("replay", str(log), port=None)  # type: ignore[arg-type]
    assert [e["message"]["message"] for e in replayed] == ["request_position", "position_feedback"]  # type: ignore[index, union-attr]


def test_help_has_examples() -> None:
    for command in ("scan", "status", "move", "set", "decode", "encode", "sim", "demo"):
        proc = cli(command, "--help")
        assert proc.returncode == 0 and ("Example" in proc.stdout or "example" in proc.stdout.lower()), command
