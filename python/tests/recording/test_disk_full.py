"""`record` on a full disk (issue 39, item 3b): the recording stops at once with one line and
exit 1, and the file stays the complete file of its last checkpoint (a failed write over the
old tail is undone). An injected failure at every point of a commit, and a real `nurimc record`
on a small tmpfs the test mounts (root only)."""

from __future__ import annotations

import contextlib
import errno
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from mcap.reader import make_reader

from nurimc.recording import checkpoint as cp
from nurimc.recording.mcap_file import FRAMES_TOPIC, McapRecorder
from nurimc.ros2 import msgs

from .test_crash import ENV
from .test_mcap import NURIMC


def frame(n: int) -> msgs.Frame:
    return msgs.Frame(
        stamp=msgs.Time.from_ns(n),
        direction="tx",
        id=1,
        name="request_ping",
        data=[255, 254, 1, 2, n % 256, 160],
        dropped_before=0,
    )


def messages(path: Path) -> int:
    with path.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None  # indexed: a complete file
        return sum(1 for _ in reader.iter_messages())


@pytest.mark.parametrize("fail_after", [0, 1, 100, 5000])
def test_a_failed_commit_leaves_the_last_checkpoint(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fail_after: int
) -> None:
    """The disk fills after `fail_after` bytes of a checkpoint's write went in."""
    path = tmp_path / "run.mcap"
    recorder = McapRecorder(path, checkpoint_seconds=0)
    for n in range(200):
        recorder.write(FRAMES_TOPIC, frame(n), n)
    cp.checkpoint(recorder._writer, recorder._stream)
    assert messages(path) == 200
    for n in range(200, 5000):
        recorder.write(FRAMES_TOPIC, frame(n), n)
    real = os.pwrite
    allocated = [path.stat().st_size + fail_after]  # blocks the file has, and what the disk still had

    def full_disk(fd: int, data: bytes, offset: int) -> int:
        """As a full disk: writes within the blocks the file has go in; past them, ENOSPC."""
        room = allocated[0] - offset
        if room <= 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, data[:room], offset)

    monkeypatch.setattr(os, "pwrite", full_disk)
    with pytest.raises(cp.CheckpointFailed) as failed:
        cp.checkpoint(recorder._writer, recorder._stream)
    assert failed.value.restored
    monkeypatch.setattr(os, "pwrite", real)
    assert messages(path) == 200  # the file of the last checkpoint, whole
    monkeypatch.setattr(os, "pwrite", full_disk)
    recorder.close()  # the end fails too: said, not raised
    assert recorder.failed is not None and "No space left on device" in recorder.failed
    assert "complete up to its last checkpoint" in recorder.failed and "\n" not in recorder.failed
    monkeypatch.setattr(os, "pwrite", real)
    assert messages(path) == 200


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs needs root")
    mount = tmp_path / "disk"
    mount.mkdir()
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=192k", "tmpfs", str(mount)], capture_output=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def test_record_on_a_nearly_full_filesystem_exits_1_with_one_line(small_disk: Path) -> None:
    path = small_disk / "run.mcap"
    filler = small_disk / "filler"
    with contextlib.suppress(OSError), filler.open("wb") as out:
        out.write(bytes(150 * 1024))  # leaves some 40 kB: a few checkpoints' worth
    proc = subprocess.run(
        [NURIMC, "--port", "sim://?ids=1,2", "record", "--mcap", str(path), "--ids", "1,2", "--rate", "0",
         "--checkpoint", "0.05", "--seconds", "120"],
        capture_output=True, text=True, timeout=100, env=ENV,
    )  # fmt: skip
    assert proc.returncode == 1, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "the recording stopped" in lines[0] and "No space left on device" in lines[0], lines
    assert "Traceback" not in proc.stderr
    assert messages(path) > 0  # opens with the mcap reader, indexed, with what came before
