"""Hostile files against the readers (issue 39, item 6 "done when"), each through the real CLI in
its own process, its peak RSS and wall time measured:

- a 1 MB `.sr` zip bomb (1 GiB of samples) through `nurimc replay`;
- a 32 KB MCAP chunk bomb (1 GiB of zeros in one zstd chunk) through `nurimc repair-mcap`;
- a recording of 556 chunks and 66,405 messages with one bit flipped in chunk 3, repaired:
  the share of messages kept.

    .venv/bin/python benchmarks/reader_bombs.py [--out benchmarks/results/reader-bombs.json]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import platform
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path
from typing import Any

import zstandard
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
MESSAGES, CHUNKS = 66_405, 556


def run(args: list[str]) -> dict[str, Any]:
    """One CLI run in a child: its exit, its stderr's lines, its peak RSS (MiB) and wall time."""
    began = time.monotonic()
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    done = subprocess.run([NURIMC, *args], capture_output=True, text=True, timeout=300)
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    lines = [line for line in (done.stderr + done.stdout).splitlines() if line.strip()]
    return {
        "exit": done.returncode,
        "seconds": round(time.monotonic() - began, 2),
        "peak_rss_mib_at_most": round(max(peak, before) / 1024, 1),  # the largest child so far
        "output_lines": len(lines),
        "last_line": lines[-1][:300] if lines else "",
    }


def sr_bomb(path: Path) -> int:
    meta = "[device 1]\ncapturefile=logic-1\ntotal probes=8\nsamplerate=1 MHz\nunitsize=1\n"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=9) as archive:
        archive.writestr("metadata", meta)
        with archive.open("logic-1-1", "w", force_zip64=True) as member:
            block = b"\xff" * (1 << 20)
            for _ in range(1024):
                member.write(block)
    return path.stat().st_size


def mcap_bomb(path: Path) -> int:
    out = io.BytesIO()
    writer = zstandard.ZstdCompressor(level=1).stream_writer(out, closefd=False)
    for _ in range(1024):
        writer.write(bytes(1 << 20))
    writer.close()  # type: ignore[no-untyped-call]
    payload = out.getvalue()
    body = struct.pack("<QQQI", 0, 0, 1 << 20, 0) + struct.pack("<I", 4) + b"zstd"
    body += struct.pack("<Q", len(payload)) + payload
    header = struct.pack("<I", 0) + struct.pack("<I", 4) + b"bomb"
    data = b"\x89MCAP0\r\n" + b"\x01" + struct.pack("<Q", len(header)) + header
    data += b"\x06" + struct.pack("<Q", len(body)) + body
    path.write_bytes(data)
    return len(payload)


def recording(path: Path) -> list[int]:
    per_chunk = -(-MESSAGES // CHUNKS)
    with path.open("wb") as out:
        writer = Writer(out, compression=CompressionType.ZSTD, chunk_size=1 << 30)  # chunks closed by hand below
        writer.start(profile="ros2", library="bench")
        channel = writer.register_channel("/n", "json", writer.register_schema("n", "jsonschema", b"{}"))
        for n in range(MESSAGES):
            writer.add_message(channel, n * 1000, b'{"n": %d, "pad": "%s"}' % (n, b"x" * (n % 50)), n * 1000)
            if (n + 1) % per_chunk == 0:
                writer.flush()  # type: ignore[no-untyped-call]  # one chunk per second of a recording
        writer.finish()  # type: ignore[no-untyped-call]
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return sorted(index.chunk_start_offset for index in summary.chunk_indexes)


def count(path: Path) -> int:
    with path.open("rb") as stream:
        return sum(1 for _ in make_reader(stream).iter_messages())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default=str(Path(__file__).parent / "results" / "reader-bombs.json"))
    args = parser.parse_args()
    result: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        size = sr_bomb(work / "bomb.sr")
        result["sr_bomb"] = {"file_bytes": size, "samples_bytes": 1 << 30, **run(["replay", str(work / "bomb.sr")])}
        size = mcap_bomb(work / "bomb.mcap")
        result["mcap_chunk_bomb"] = {
            "chunk_bytes": size,
            "decompresses_to": 1 << 30,
            **run(["repair-mcap", str(work / "bomb.mcap"), "--out", str(work / "bomb.fixed.mcap")]),
        }
        chunks = recording(work / "run.mcap")
        data = bytearray((work / "run.mcap").read_bytes())
        data[chunks[2] + 9 + 80] ^= 0x04  # one bit, inside chunk 3's compressed records
        (work / "flipped.mcap").write_bytes(bytes(data))
        repaired = run(["repair-mcap", str(work / "flipped.mcap"), "--out", str(work / "fixed.mcap")])
        kept = count(work / "fixed.mcap")
        result["bit_flip_in_chunk_3"] = {
            "chunks": len(chunks),
            "messages": MESSAGES,
            "kept": kept,
            "kept_share": round(kept / MESSAGES, 4),
            **repaired,
        }
    result["python"] = platform.python_version()
    result["cpus"] = os.cpu_count()
    result["when"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    result["note"] = "busy 2-core host shared with other agents; peak RSS is the largest child process so far"
    print(json.dumps(result, indent=2))
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
