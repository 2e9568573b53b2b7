"""nurimc.recording.sigrok's own reading of sigrok session files (no sigrok-cli): the baud rate told from
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
from nurimc.recording.sigrok import read_capture


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


# -- budgets (issue 39, item 6): hostile captures end in one line, in bounded memory and time ----


def bomb(path: Path, size: int, pattern: bytes = b"\xff", probes: int = 8, unitsize: int = 1) -> Path:
    meta = (
        "[global]\nsigrok version=0.5.2\n\n[device 1]\ncapturefile=logic-1\n"
        f"total probes={probes}\nsamplerate=1 MHz\ntotal analog=0\nunitsize={unitsize}\n"
    )
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as archive:
        archive.writestr("metadata", meta)
        with archive.open("logic-1-1", "w", force_zip64=True) as member:
            block = pattern * ((1 << 20) // len(pattern))
            for _ in range(size >> 20):
                member.write(block)
    return path


def peak_rss_mib() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def test_a_zip_bomb_stops_at_the_samples_limit(tmp_path: Path) -> None:
    import time

    path = bomb(tmp_path / "bomb.sr", 256 << 20)  # 256 MiB of samples, 250 kB on disk
    assert path.stat().st_size < 1 << 20
    began = time.monotonic()
    with pytest.raises(InputError) as refused:
        read_capture(path)
    message = str(refused.value)
    assert "decompressed samples" in message and "64 MiB" in message and "--read-limits" in message
    assert "\n" not in message and time.monotonic() - began < 10


def test_toggling_samples_stop_at_the_edge_limit(tmp_path: Path) -> None:
    from nurimc.budgets import ReadBudget

    path = bomb(tmp_path / "toggle.sr", 8 << 20, pattern=b"\x00\xff")  # every sample an edge on 8 lines
    with pytest.raises(InputError, match="signal edges over the limit of 2,000,000"):
        read_capture(path)
    with pytest.raises(InputError, match="signal edges over the limit of 1,000 "):
        read_capture(path, budget=ReadBudget(edges=1000))


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("unitsize", "100000000", "unitsize '100000000' is not a whole number 1..8"),
        ("unitsize", "x", "unitsize 'x' is not a whole number"),
        ("total probes", "99999", "total probes '99999' is not a whole number 1..64"),
        ("samplerate", "... Hz", "samplerate '... Hz' is not a rate"),
        ("samplerate", "0 Hz", "samplerate '0 Hz' is not a rate"),
        ("samplerate", "1e999 GHz", "samplerate '1e999 GHz' is not a rate"),
    ],
)
def test_bad_metadata_is_one_line(tmp_path: Path, field: str, value: str, message: str) -> None:
    values = {"total probes": "8", "samplerate": "1 MHz", "unitsize": "1", field: value}
    meta = "[device 1]\ncapturefile=logic-1\n" + "".join(f"{k}={v}\n" for k, v in values.items())
    path = tmp_path / "m.sr"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("metadata", meta)
        archive.writestr("logic-1-1", b"\x01\x00" * 10)
    with pytest.raises(InputError) as refused:
        read_capture(path)
    assert message in str(refused.value) and "\n" not in str(refused.value)


def test_limits_are_raised_by_name() -> None:
    from nurimc.budgets import ReadBudget

    assert ReadBudget().with_text("samples=1024, records=5").samples == 1024
    for bad in ("samples", "warp=3", "edges=0", "edges=lots"):
        with pytest.raises(InputError, match="read limit"):
            ReadBudget().with_text(bad)
