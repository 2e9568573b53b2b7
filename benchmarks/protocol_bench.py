#!/usr/bin/env python3
"""Micro-benchmark of the Python protocol layer, with the hand-written parser it must beat.

Usage: python benchmarks/protocol_bench.py [--quick]

Stream parsing is measured against `HandParser` below, the parser a user would write
by hand (bytes.find for the header, the checksum, one precompiled struct.Struct per
mode, tuples out), on the same streams and chunkings: mixed messages and position
feedback, in 64- and 12-byte chunks. The two run in interleaved rounds (A, B, A, B, ...)
so that a slow moment of the machine hits both; the figure is the median round, and the
ratio is hand-written time / StreamParser time (above 1.0 = StreamParser is faster).
Encode and decode rates are printed for reference. Writes
benchmarks/results/protocol-python.json (not with --quick). Not a test: figures vary with
the machine and never fail anything.
"""

from __future__ import annotations

import gc
import json
import platform
import random
import statistics
import struct
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from nurimc.protocol import SPECS, Message, StreamParser, decode, make

RESULTS = Path(__file__).resolve().parent / "results" / "protocol-python.json"


class HandParser:
    """The baseline: a straightforward, reasonably optimized hand-written stream parser.

    Same stream rule as StreamParser (a bad candidate costs one byte), but no typed
    messages, no diagnostics counters: it yields (mode, id, fields) tuples.
    """

    LAYOUTS: ClassVar[dict[int, tuple[int, struct.Struct]]] = {
        spec.mode: (spec.size, struct.Struct(">" + spec.layout.format[1:])) for spec in SPECS.values()
    }

    def __init__(self) -> None:
        self.buf = bytearray()

    def feed(self, chunk: bytes) -> list[tuple[int, int, tuple[int, ...]]]:
        buf = self.buf
        buf += chunk
        layouts = self.LAYOUTS
        out = []
        pos, n = 0, len(buf)
        while True:
            start = buf.find(b"\xff\xfe", pos)
            if start < 0:
                pos = n - 1 if n and buf[-1] == 0xFF else n  # FF may begin a header
                break
            pos = start
            if n - start < 6:
                break
            size = buf[start + 3]
            mode = buf[start + 5]
            layout = layouts.get(mode)
            if layout is None or layout[0] != size:
                pos += 1
                continue
            end = start + size + 4
            if end > n:
                break
            if buf[start + 4] != ~(buf[start + 2] + size + sum(buf[start + 5 : end])) & 0xFF:
                pos += 1
                continue
            out.append((mode, buf[start + 2], layout[1].unpack_from(buf, start + 6)))
            pos = end
        del buf[:pos]
        return out


def sample_messages(count: int, names: list[str] | None = None) -> list[Message]:
    rng = random.Random(1)
    names = names or sorted(SPECS)
    out = []
    for _ in range(count):
        spec = SPECS[rng.choice(names)]
        fields = {f.name: rng.randint(f.min, f.max) for f in spec.fields}
        out.append(make(spec.name, rng.randint(0, spec.max_id), **fields))
    return out


def chunked(stream: bytes, size: int) -> list[bytes]:
    return [stream[i : i + size] for i in range(0, len(stream), size)]


def run_ours(chunks: list[bytes]) -> int:
    parser = StreamParser()
    feed = parser.feed
    count = 0
    for chunk in chunks:
        count += len(feed(chunk))
    return count


def run_hand(chunks: list[bytes]) -> int:
    parser = HandParser()
    feed = parser.feed
    count = 0
    for chunk in chunks:
        count += len(feed(chunk))
    return count


def timed(fn: Callable[[list[bytes]], int], chunks: list[bytes], frames: int) -> float:
    gc.collect()
    start = time.perf_counter()
    got = fn(chunks)
    elapsed = time.perf_counter() - start
    if got != frames:
        raise SystemExit(f"{fn.__name__} returned {got} frames, expected {frames}")
    return elapsed


def compare(chunks: list[bytes], frames: int, rounds: int) -> dict[str, Any]:
    """Interleaved rounds of both parsers on the same chunks (the order alternating).

    The ratio is the median of each round's own ratio: the two runs of a round are next to
    each other in time, so a busy moment of the machine slows both.
    """
    ours, hand, ratios = [], [], []
    for i in range(rounds):
        if i % 2:
            h, o = timed(run_hand, chunks, frames), timed(run_ours, chunks, frames)
        else:
            o, h = timed(run_ours, chunks, frames), timed(run_hand, chunks, frames)
        ours.append(o)
        hand.append(h)
        ratios.append(h / o)
    return {
        "stream_parser_frames_per_s": round(frames / statistics.median(ours), 1),
        "hand_written_frames_per_s": round(frames / statistics.median(hand), 1),
        "ratio": round(statistics.median(ratios), 3),
        "ratio_of_median_times": round(statistics.median(hand) / statistics.median(ours), 3),
    }


def best_rate(fn: Callable[[], object], items: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return items / best


def main() -> None:
    quick = "--quick" in sys.argv
    count = 5_000 if quick else 20_000
    rounds = 11 if quick else 31
    streams = {
        "mixed": b"".join(m.encode() for m in sample_messages(count)),
        "feedback": b"".join(m.encode() for m in sample_messages(count, ["position_feedback"])),
    }
    parsing: dict[str, Any] = {}
    for name, stream in streams.items():
        for size in (64, 12):
            key = f"{name}_{size}_byte_chunks"
            parsing[key] = compare(chunked(stream, size), count, rounds)
            r = parsing[key]
            print(
                f"{key:26s} StreamParser {r['stream_parser_frames_per_s']:12,.0f} frames/s  "
                f"hand-written {r['hand_written_frames_per_s']:12,.0f} frames/s  ratio {r['ratio']:.2f}"
            )
    messages = sample_messages(count)
    frames = [m.encode() for m in messages]
    codec = {
        "encode_frames_per_s": round(best_rate(lambda: [m.encode() for m in messages], count, 5), 1),
        "decode_frames_per_s": round(best_rate(lambda: [decode(f) for f in frames], count, 5), 1),
    }
    for key, value in codec.items():
        print(f"{key:26s} {value:14,.0f}")
    record = {
        "benchmark": "benchmarks/protocol_bench.py: StreamParser against a hand-written bytes.find + checksum + "
        "struct.unpack parser on the same chunks, interleaved rounds; ratio = hand-written time / StreamParser "
        "time, the median over rounds (>= 1.0: StreamParser is as fast or faster); ratio_of_median_times = "
        "the same from the median times",
        "parsing": parsing,
        "min_ratio": min(r["ratio"] for r in parsing.values()),
        "codec": codec,
        "frames_per_stream": count,
        "rounds": rounds,
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "machine": f"{platform.machine()} {platform.processor() or ''}".strip(),
        "date": time.strftime("%Y-%m-%d"),
    }
    print(f"lowest ratio: {record['min_ratio']:.2f}")
    if not quick:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(json.dumps(record, indent=2) + "\n")
        print(f"written: {RESULTS}")


if __name__ == "__main__":
    main()
