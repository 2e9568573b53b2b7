"""Damaged and hostile MCAP files (issue 39, item 6): a broken chunk is skipped and the repair goes
on with the next good one; a chunk bomb ends in one line, in bounded memory and time."""

from __future__ import annotations

import io
import struct
import time
from pathlib import Path

import pytest
import zstandard
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from nurimc.budgets import ReadBudget
from nurimc.errors import InputError
from nurimc.recording.repair import repair
from nurimc.recording.salvage import MAGIC, Salvage, read_records

MESSAGES = 20_000


def recording(path: Path, messages: int = MESSAGES, chunk_size: int = 2048) -> list[int]:
    """A chunked recording; the offsets of its chunks."""
    with path.open("wb") as out:
        writer = Writer(out, compression=CompressionType.ZSTD, chunk_size=chunk_size)
        writer.start(profile="", library="test")
        schema = writer.register_schema("n", "jsonschema", b"{}")
        channel = writer.register_channel("/n", "json", schema)
        for n in range(messages):
            writer.add_message(channel, n * 1000, b'{"n": %d, "pad": "%s"}' % (n, b"x" * (n % 40)), n * 1000)
        writer.finish()  # type: ignore[no-untyped-call]
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return sorted(index.chunk_start_offset for index in summary.chunk_indexes)


def kept(path: Path) -> int:
    with path.open("rb") as stream:
        return sum(1 for _ in make_reader(stream).iter_messages())


def flip(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0x10
    path.write_bytes(bytes(data))


def test_a_bit_flip_in_chunk_3_loses_only_that_chunk(tmp_path: Path) -> None:
    source = tmp_path / "run.mcap"
    chunks = recording(source)
    assert len(chunks) > 200
    flip(source, chunks[2] + 9 + 60)  # inside chunk 3's compressed records
    result = repair(source, tmp_path / "fixed.mcap")
    assert not result.complete and len(result.lost) == 1 and "chunk at byte" in result.lost[0]
    assert kept(tmp_path / "fixed.mcap") == result.messages >= 0.99 * MESSAGES
    assert "\n" not in result.problem


def test_a_broken_chunk_length_is_passed_by_finding_the_next_chunk(tmp_path: Path) -> None:
    source = tmp_path / "run.mcap"
    chunks = recording(source)
    data = bytearray(source.read_bytes())
    struct.pack_into("<Q", data, chunks[2] + 1, 1 << 50)  # chunk 3 claims a length past the end
    source.write_bytes(bytes(data))
    result = repair(source, tmp_path / "fixed.mcap")
    assert any("unreadable" in line for line in result.lost)
    assert result.messages >= 0.98 * MESSAGES and kept(tmp_path / "fixed.mcap") == result.messages


def test_an_undamaged_file_is_complete(tmp_path: Path) -> None:
    source = tmp_path / "run.mcap"
    recording(source, messages=500)
    result = repair(source, tmp_path / "fixed.mcap")
    assert result.complete and result.messages == 500 and not result.lost


def chunk_record(payload: bytes, declared: int, compression: str = "zstd") -> bytes:
    name = compression.encode()
    body = struct.pack("<QQQI", 0, 0, declared, 0) + struct.pack("<I", len(name)) + name
    body += struct.pack("<Q", len(payload)) + payload
    return bytes((0x06,)) + struct.pack("<Q", len(body)) + body


def header_record() -> bytes:
    body = struct.pack("<I", 0) + struct.pack("<I", 4) + b"bomb"
    return bytes((0x01,)) + struct.pack("<Q", len(body)) + body


def zstd_zeros(size: int) -> bytes:
    out = io.BytesIO()
    compressor = zstandard.ZstdCompressor(level=1).stream_writer(out, closefd=False)
    block = bytes(1 << 20)
    for _ in range(size >> 20):
        compressor.write(block)
    compressor.close()  # type: ignore[no-untyped-call]
    return out.getvalue()


@pytest.fixture(scope="module")
def bomb_payload() -> bytes:
    payload = zstd_zeros(1 << 30)  # 1 GiB of zeros
    assert len(payload) < 64 << 10
    return payload


@pytest.mark.parametrize(
    ("declared", "reason"), [(1 << 30, "over the 64 MiB limit"), (1 << 20, "decompresses to other")]
)
def test_a_chunk_bomb_is_skipped_in_bounded_memory(
    tmp_path: Path, bomb_payload: bytes, declared: int, reason: str
) -> None:
    source = tmp_path / "bomb.mcap"
    bomb = chunk_record(bomb_payload, declared)
    source.write_bytes(MAGIC + header_record() + bomb + bomb)
    began = time.monotonic()
    found = Salvage()
    with source.open("rb") as stream:
        records = list(read_records(stream, found=found))
    assert time.monotonic() - began < 10
    assert len(records) == 1 and len(found.lost) == 2 and all(reason in line for line in found.lost)
    assert found.decompressed == 0


def test_the_total_decompressed_budget_ends_the_read_in_one_line(tmp_path: Path) -> None:
    source = tmp_path / "run.mcap"
    recording(source, messages=2000)
    with source.open("rb") as stream, pytest.raises(InputError) as refused:
        list(read_records(stream, ReadBudget(decompressed=0)))
    assert "over the limit" in str(refused.value) and "\n" not in str(refused.value)


def test_not_an_mcap_file(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello" * 100)
    with pytest.raises(ValueError, match="is not an MCAP file"):
        repair(junk, tmp_path / "out.mcap")


def test_repair_mcap_of_a_chunk_bomb_is_one_line_and_exit_2(tmp_path: Path, bomb_payload: bytes) -> None:
    import subprocess

    from .test_crash import ENV
    from .test_mcap import NURIMC

    source = tmp_path / "bomb.mcap"
    source.write_bytes(MAGIC + header_record() + chunk_record(bomb_payload, 1 << 20))
    done = subprocess.run(
        [NURIMC, "repair-mcap", str(source), "--out", str(tmp_path / "out.mcap")],
        capture_output=True, text=True, timeout=60, env=ENV,
    )  # fmt: skip
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert done.returncode == 2 and len(lines) == 1 and "nothing kept from" in lines[0], done.stderr
    assert "decompresses to other than its declared" in lines[0] and not done.stdout.strip()
