"""nurimc.sigrok's own reading of sigrok session files (no sigrok-cli): the baud rate told from
the pulses at several rates, a channel in the second byte of 16-channel samples, bad files."""

from __future__ import annotations

import random
import sys
import zipfile
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from synth import Line, capture, expected_frames
from test_replay import in_range_frame

from nurimc.errors import InputError
from nurimc.sigrok import read_capture


def session(path: Path, samples: bytes, samplerate: str, unitsize: int = 1, probes: int = 8) -> Path:
    meta = (
        "[global]\nsigrok version=0.5.2\n\n[device 1]\ncapturefile=logic-1\n"
        f"total probes={probes}\nsamplerate={samplerate}\ntotal analog=0\nunitsize={unitsize}\n"
    )
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("version", "2")
        archive.writestr("metadata", meta)
        half = len(samples) // 2 // unitsize * unitsize  # two logic files, as long captures have
        archive.writestr("logic-1-1", samples[:half])
        archive.writestr("logic-1-2", samples[half:])
    return path


def traffic(rng: random.Random, count: int = 25) -> Line:
    line = Line()
    for _ in range(count):
        line.bursts.append((rng.uniform(3, 25), in_range_frame(rng, ("command", "request", "answer"))))
    line.bursts.append((60, b""))
    return line


@pytest.mark.parametrize(("baud", "samplerate", "text"), [(9600, 200_000, "200 kHz"), (57600, 1_000_000, "1 MHz"),
                                                         (1_000_000, 12_000_000, "12 MHz")])  # fmt: skip
def test_the_baud_rate_is_told_from_the_pulses(tmp_path: Path, baud: int, samplerate: int, text: str) -> None:
    rng = random.Random(baud)
    line = traffic(rng)
    samples = capture([line], rng, samplerate, baud)
    entries = read_capture(session(tmp_path / "c.sr", samples, text))
    assert entries is not None
    assert [e[2] for e in entries] == expected_frames(line)
    times = [e[0] for e in entries]  # each frame's first start bit, in seconds
    assert times == sorted(times) and times[0] > 0 and times[-1] < len(samples) / samplerate


def test_a_channel_of_sixteen(tmp_path: Path) -> None:
    rng = random.Random(3)
    line = traffic(rng)
    low = capture([Line([(0, b"")]), line], rng, 1_000_000, 9600)  # channel 1 carries the bus
    samples = bytearray()
    for value in low:  # channel 1 moves to channel 9: the second byte of each 2-byte sample
        samples += bytes((0xFF, 0xFD | (value & 2)))
    path = session(tmp_path / "c.sr", bytes(samples), "1 MHz", unitsize=2, probes=16)
    entries = read_capture(path, baud=9600)
    assert entries is not None and [e[2] for e in entries] == expected_frames(line)


def test_bad_session_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="samplerate 'fast' is not a rate"):
        read_capture(session(tmp_path / "a.sr", b"\x01\x00\x01", "fast"))
    with pytest.raises(InputError, match="no logic samples"):
        read_capture(session(tmp_path / "b.sr", b"", "1 MHz"))
    broken = tmp_path / "c.sr"
    broken.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InputError, match="not a readable sigrok session file"):
        read_capture(broken)
