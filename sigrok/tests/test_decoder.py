"""The sigrok decoder through sigrok-cli, on captures synthesized here, against the Python stream parser.

Run: .venv/bin/python -m pytest sigrok/tests (make test-sigrok). Needs sigrok-cli (Debian 12:
0.7.2 with libsigrokdecode 0.5.3, decoder API 3).
"""

from __future__ import annotations

import json
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from synth import Line, capture, expected_frames, traffic

from nurimc.protocol import BY_MODE, StreamParser

SIGROK = Path(__file__).resolve().parents[1]
ROOT = SIGROK.parent


def sigrok_cli_bytes(path: Path, samplerate: int, uart: str, *outputs: str) -> bytes:
    env = dict(os.environ, SIGROKDECODE_DIR=str(SIGROK))
    cmd = ["sigrok-cli", "-I", f"binary:samplerate={samplerate}", "-i", str(path), "-P", f"{uart},nurimc", *outputs]
    done = subprocess.run(cmd, capture_output=True, env=env, timeout=120, check=False)
    assert done.returncode == 0 and not done.stderr, done.stderr.decode()
    return done.stdout


def sigrok_cli(path: Path, samplerate: int, uart: str, *outputs: str) -> str:
    return sigrok_cli_bytes(path, samplerate, uart, *outputs).decode()


def run(tmp_path: Path, lines: list[Line], samplerate: int, baud: int, seed: int) -> tuple[Path, str]:
    path = tmp_path / "capture.bin"
    path.write_bytes(capture(lines, random.Random(seed), samplerate, baud))
    channels = "uart:rx=0:tx=1" if len(lines) == 2 else "uart:rx=0"
    return path, f"{channels}:baudrate={baud}"


def log_entries(path: Path, samplerate: int, uart: str) -> list[dict[str, object]]:
    text = sigrok_cli(path, samplerate, uart, "-B", "nurimc=log")
    return [json.loads(line) for line in text.splitlines()]


def frame_labels(path: Path, samplerate: int, uart: str) -> list[str]:
    """`<role>: <message name> id=<ID>` of every frame annotation, in order."""
    text = sigrok_cli(path, samplerate, uart, "-A", "nurimc=host:controller")
    return [re.sub(r"^nurimc-1: ", "", line).split(" ", 3)[:3] for line in text.splitlines()]  # type: ignore[misc]


def label(frame: bytes) -> tuple[str, str]:
    spec = BY_MODE[frame[5]].SPEC
    role = "host" if spec.kind in ("command", "request") else "controller"
    return role, f"{spec.name} id={frame[2]}"


@pytest.mark.parametrize(
    ("baud", "samplerate", "seed"),
    [(9600, 1_000_000, 1), (9600, 250_000, 2), (115200, 2_000_000, 3), (115200, 1_000_000, 4)],
)
def test_half_duplex_line_decodes_to_exactly_the_frames_it_holds(
    tmp_path: Path, baud: int, samplerate: int, seed: int
) -> None:
    host, _ = traffic(random.Random(seed), 60, two_lines=False)  # requests, answers and noise on one pair
    path, uart = run(tmp_path, [host], samplerate, baud, seed)
    expected = expected_frames(host)
    assert len(expected) > 80
    entries = log_entries(path, samplerate, uart)
    assert [e["hex"] for e in entries] == [f.hex() for f in expected]
    assert [e["dir"] for e in entries] == ["tx" if label(f)[0] == "host" else "rx" for f in expected]
    times = [float(e["t"]) for e in entries]  # type: ignore[arg-type]
    assert times == sorted(times) and 0 < times[0] < times[-1] < len(path.read_bytes()) / samplerate
    labels = frame_labels(path, samplerate, uart)
    assert [(role.rstrip(":"), f"{name} {ident}") for role, name, ident in labels] == [label(f) for f in expected]
    assert sigrok_cli_bytes(path, samplerate, uart, "-B", "nurimc=frames") == b"".join(expected)


def test_two_lines_tell_host_and_controller_apart(tmp_path: Path) -> None:
    host, controller = traffic(random.Random(5), 60, two_lines=True)
    path, uart = run(tmp_path, [host, controller], 2_000_000, 115200, 5)
    entries = log_entries(path, 2_000_000, uart)
    assert [e["hex"] for e in entries if e["dir"] == "tx"] == [f.hex() for f in expected_frames(host)]
    assert [e["hex"] for e in entries if e["dir"] == "rx"] == [f.hex() for f in expected_frames(controller)]
    text = sigrok_cli(path, 2_000_000, uart, "-A", "nurimc=host:controller")
    assert "controller (TX line): " in text and "host (RX line): " in text
    assert "host (TX line)" not in text or "controller (TX line): " not in text.split("host (TX line)")[0]


def test_noise_is_flagged_as_the_parser_counts_it(tmp_path: Path) -> None:
    host, _ = traffic(random.Random(6), 80, two_lines=False)
    path, uart = run(tmp_path, [host], 1_000_000, 9600, 6)
    parser = StreamParser()
    for gap, data in host.bursts:
        if gap >= 45:
            parser.finish()
        parser.feed(data)
    parser.finish()
    text = sigrok_cli(path, 1_000_000, uart, "-A", "nurimc=garbage:error:checksum-bad")
    stats = parser.stats
    assert stats.bad_checksum and stats.unknown_mode and stats.bad_size and stats.dropped_bytes
    assert text.count("Rejected: bad checksum") == stats.bad_checksum
    assert text.count("Checksum bad") + text.count(" bad (0x") >= stats.bad_checksum
    assert text.count("Rejected: unknown mode") == stats.unknown_mode
    assert text.count("Rejected: size") + text.count("Rejected: wrong size") == stats.bad_size
    dropped = sum(int(n) for n in re.findall(r"Garbage: (\d+) bytes?", text))
    assert dropped == stats.dropped_bytes
    assert "UART frame error" in text  # the idle glitches: a start bit that is high at mid-bit


def test_physical_units_in_the_field_annotations(tmp_path: Path) -> None:
    frame = bytes.fromhex("fffe0007760100465003e8")  # position_speed 180.00 deg at 100.0 rpm
    frame = bytes.fromhex("fffe00077601004650" + "03e8")
    line = Line([(20, frame), (60, b"")])
    path, uart = run(tmp_path, [line], 1_000_000, 9600, 7)
    text = sigrok_cli(path, 1_000_000, uart, "-A", "nurimc")
    for want in (
        "Header FF FE",
        "ID 0",
        "Size 7",
        "Checksum 0x76 good",
        "Mode 0x01 position_speed",
        "direction: ccw",
        "position: 180.00 deg",
        "speed: 100.0 rpm",
        "host: position_speed id=0 direction=ccw position=180.00 deg speed=100.0 rpm",
    ):
        assert f"nurimc-1: {want}\n" in text, want


def test_generated_table_is_current() -> None:
    done = subprocess.run([sys.executable, str(SIGROK / "gen_tables.py"), "--check"], capture_output=True, check=False)
    assert done.returncode == 0, done.stderr.decode()
