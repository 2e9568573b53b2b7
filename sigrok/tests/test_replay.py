"""From the analyzer back into the tools: `nurimc replay` and `nurimc record --mcap --from` read a
sigrok session file (.sr) and the nurimc decoder's binary outputs, and find exactly the frames the
capture holds (synthesized here, in-range values so every frame can be shown in units)."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from synth import Line, capture, expected_frames, noise_burst

from nurimc.protocol import BY_MODE, Message

SIGROK = Path(__file__).resolve().parents[1]
NURIMC = Path(sys.executable).parent / "nurimc"


def in_range_frame(rng: random.Random, kinds: tuple[str, ...]) -> bytes:
    cls: type[Message] = rng.choice([c for c in BY_MODE.values() if c.SPEC.kind in kinds])
    values = [rng.randint(f.min, f.max) for f in cls.SPEC.fields]
    return cls(rng.randint(0, 254), *values).encode()


def exchange(rng: random.Random, two_lines: bool, count: int = 40) -> list[Line]:
    host, controller = Line(), Line()
    for _ in range(count):
        host.bursts.append((rng.uniform(3, 25), in_range_frame(rng, ("command", "request"))))
        (controller if two_lines else host).bursts.append((rng.uniform(3, 25), in_range_frame(rng, ("answer",))))
        if rng.random() < 0.3:
            host.bursts.append((rng.uniform(3, 25), noise_burst(rng)))
    for line in (host, controller):
        line.bursts.append((60, b""))
    return [host, controller] if two_lines else [host]


def sigrok(*args: str, out: Path | None = None) -> None:
    env = dict(os.environ, SIGROKDECODE_DIR=str(SIGROK))
    with open(out, "wb") if out else open(os.devnull, "wb") as sink:
        done = subprocess.run(["sigrok-cli", *args], env=env, stdout=sink, stderr=subprocess.PIPE, check=False)
    assert done.returncode == 0 and not done.stderr, done.stderr.decode()


def replay(path: Path) -> list[tuple[str, str, int]]:
    done = subprocess.run([str(NURIMC), "--json", "replay", str(path)], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    entries = json.loads(done.stdout)
    assert all("error" not in e for e in entries), entries
    return [(e["dir"], e["message"]["message"], e["message"]["id"]) for e in entries]


def described(frames: list[bytes]) -> list[tuple[str, str, int]]:
    out = []
    for frame in frames:
        spec = BY_MODE[frame[5]].SPEC
        out.append(("tx" if spec.kind in ("command", "request") else "rx", spec.name, frame[2]))
    return out


@pytest.mark.parametrize(("baud", "samplerate", "two_lines"), [(9600, 1_000_000, False), (115200, 2_000_000, True)])
def test_replay_reads_a_session_file_and_the_decoder_outputs(
    tmp_path: Path, baud: int, samplerate: int, two_lines: bool
) -> None:
    rng = random.Random(baud)
    lines = exchange(rng, two_lines)
    (tmp_path / "c.bin").write_bytes(capture(lines, rng, samplerate, baud))
    session = tmp_path / "capture.sr"
    sigrok("-I", f"binary:samplerate={samplerate}", "-i", str(tmp_path / "c.bin"), "-o", str(session))
    uart = f"uart:rx=0:tx=1:baudrate={baud},nurimc" if two_lines else f"uart:rx=0:baudrate={baud},nurimc"
    sigrok("-i", str(session), "-P", uart, "-B", "nurimc=log", out=tmp_path / "decoded.log")
    sigrok("-i", str(session), "-P", uart, "-B", "nurimc=frames", out=tmp_path / "decoded.frames")
    sigrok("-i", str(session), "-P", uart, "-B", "nurimc", out=tmp_path / "decoded.both")  # every class
    expected = [described(expected_frames(line)) for line in lines]
    for path in (session, tmp_path / "decoded.log", tmp_path / "decoded.frames", tmp_path / "decoded.both"):
        got = replay(path)
        if two_lines:  # two lines: each in its own order; replay sorts a session by time
            assert [g for g in got if g[0] == "tx"] == expected[0], path
            assert [g for g in got if g[0] == "rx"] == expected[1], path
        else:
            assert got == expected[0], path


def test_record_converts_a_capture_to_mcap(tmp_path: Path) -> None:
    rng = random.Random(7)
    lines = exchange(rng, two_lines=False, count=20)
    (tmp_path / "c.bin").write_bytes(capture(lines, rng, 1_000_000, 9600))
    session = tmp_path / "capture.sr"
    sigrok("-I", "binary:samplerate=1000000", "-i", str(tmp_path / "c.bin"), "-o", str(session))
    mcap_path = tmp_path / "capture.mcap"
    done = subprocess.run(
        [str(NURIMC), "record", "--mcap", str(mcap_path), "--from", str(session)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    from mcap.reader import make_reader

    with open(mcap_path, "rb") as file:
        messages = [(channel.topic, message.log_time) for _, channel, message in make_reader(file).iter_messages()]
    assert len(messages) == len(expected_frames(lines[0])) > 30
    assert {topic for topic, _ in messages} == {"/nurimc/frames"}
    assert [t for _, t in messages] == sorted(t for _, t in messages)


def test_a_file_that_is_neither_is_refused_in_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.frames"
    bad.write_bytes(b"\xff\xfe\x00\x02\x5d\xa0" + b"\x01\x02\x03")  # a ping, then three stray bytes
    done = subprocess.run([str(NURIMC), "replay", str(bad)], capture_output=True, text=True, check=False)
    assert done.returncode != 0 and "3 byte(s) are not whole frames" in done.stderr
    assert "Traceback" not in done.stderr
    zipped = tmp_path / "not-sigrok.sr"
    import zipfile

    with zipfile.ZipFile(zipped, "w") as archive:
        archive.writestr("hello.txt", "hi")
    done = subprocess.run([str(NURIMC), "replay", str(zipped)], capture_output=True, text=True, check=False)
    assert done.returncode != 0 and "not a sigrok session file" in done.stderr
