"""atheris fuzz target: the stream parser and the decoder on arbitrary bytes.

Short run (part of `make test`): make fuzz-python-short
Long run: make fuzz-python  (or: python python/fuzz/fuzz_parser.py -max_total_time=3600)
Invariants checked: nothing but DecodeError is raised; every byte is either in a frame or
counted as dropped; the parser holds at most one frame's worth of bytes between calls.
"""

from __future__ import annotations

import contextlib
import sys

import atheris

with atheris.instrument_imports():
    from nurimc.protocol import DecodeError, StreamParser, decode


def test_one_input(data: bytes) -> None:
    fdp = atheris.FuzzedDataProvider(data)
    chunk = fdp.ConsumeIntInRange(1, 16)
    stream = fdp.ConsumeBytes(fdp.remaining_bytes())
    with contextlib.suppress(DecodeError):  # the only error decode may raise
        decode(stream)
    parser = StreamParser()
    frame_bytes = 0
    for start in range(0, len(stream), chunk):
        for message in parser.feed(stream[start : start + chunk]):
            frame_bytes += message.SPEC.size + 4
        if parser.pending > 12:
            raise AssertionError(f"parser holds {parser.pending} bytes")
    for message in parser.finish():
        frame_bytes += message.SPEC.size + 4
    if frame_bytes + parser.stats.dropped_bytes != len(stream):
        raise AssertionError("bytes unaccounted for")


if __name__ == "__main__":
    atheris.Setup(sys.argv, test_one_input)
    atheris.Fuzz()
