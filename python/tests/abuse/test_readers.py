"""Hostile files against every reader, under hypothesis (issue 39, item 8): whatever the bytes,
a reader returns within its budget or refuses with one line (an InputError); memory stays
within a bound set by the budget, never by what the file claims."""

from __future__ import annotations

import io
import json
import struct
import tracemalloc
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.writer import CompressionType, Writer

from nurimc.budgets import MIB, ReadBudget
from nurimc.errors import InputError
from nurimc.procedures.backup import BackupError, load
from nurimc.recording.salvage import Salvage, read_records
from nurimc.recording.sigrok import read_capture
from nurimc.transport.trafficlog import read_traffic_log

FAST = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
SMALL = ReadBudget(samples=1, edges=20_000, probes=16, chunk=1, decompressed=4, records=200)


def peak_bytes(work: Callable[[], Any]) -> tuple[Any, int]:
    """What `work` returned (or the InputError it raised) and the peak of Python memory it took."""
    tracemalloc.start()
    try:
        try:
            result: Any = work()
        except InputError as error:
            result = error
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def one_line(error: Exception) -> None:
    assert "\n" not in str(error) and str(error), repr(error)


# -- sigrok session files ---------------------------------------------------------------------

METADATA = st.fixed_dictionaries(
    {
        "samplerate": st.sampled_from(["1 MHz", "0 Hz", "1e9 GHz", "fast", "...", "12 kHz", "-5 Hz", ""]),
        "unitsize": st.sampled_from(["1", "2", "0", "100000000", "x", "-1"]),
        "total probes": st.sampled_from(["8", "16", "0", "99999", "two"]),
    }
)


def session(meta: dict[str, str], samples: bytes, level: int) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=level) as archive:
        archive.writestr(
            "metadata", "[device 1]\ncapturefile=logic-1\n" + "".join(f"{k}={v}\n" for k, v in meta.items())
        )
        archive.writestr("logic-1-1", samples)
    return out.getvalue()


@FAST
@given(
    meta=METADATA,
    pattern=st.binary(min_size=1, max_size=16),
    repeat=st.integers(1, 300_000),
    level=st.integers(1, 9),
)
def test_sigrok_sessions_stay_in_budget(tmp_path_factory: Any, meta: dict[str, str], pattern: bytes, repeat: int,
                                        level: int) -> None:  # fmt: skip
    path = tmp_path_factory.mktemp("sr") / "c.sr"
    path.write_bytes(session(meta, pattern * repeat, level))
    result, peak = peak_bytes(lambda: read_capture(path, budget=SMALL))
    if isinstance(result, InputError):
        one_line(result)
    else:
        assert result is not None and len(result) <= SMALL.records
    assert peak < 12 * SMALL.samples * MIB, f"{peak / MIB:.1f} MiB for a {SMALL.samples} MiB budget"


@FAST
@given(data=st.binary(max_size=4096))
def test_sigrok_garbage_is_one_line(tmp_path_factory: Any, data: bytes) -> None:
    path = tmp_path_factory.mktemp("sr") / "c.sr"
    path.write_bytes(b"PK\x03\x04" + data)
    result, _ = peak_bytes(lambda: read_capture(path, budget=SMALL))
    assert isinstance(result, InputError)
    one_line(result)


# -- traffic logs -----------------------------------------------------------------------------

HEX = st.text("0123456789abcdefg", max_size=30)
LINE = st.one_of(
    st.builds(lambda t, d, h: json.dumps({"t": t, "dir": d, "hex": h}).encode() + b"\n",
              st.floats(allow_nan=True), st.sampled_from(["tx", "rx", "up", ""]), HEX),
    st.binary(max_size=200).map(lambda b: b + b"\n"),
)  # fmt: skip


@FAST
@given(lines=st.lists(LINE, max_size=400))
def test_traffic_logs_stay_in_budget(tmp_path_factory: Any, lines: list[bytes]) -> None:
    path = tmp_path_factory.mktemp("log") / "traffic.log"
    path.write_bytes(b"".join(lines))
    result, _ = peak_bytes(lambda: read_traffic_log(str(path), SMALL))
    if isinstance(result, InputError):
        one_line(result)
    else:
        assert len(result) <= SMALL.records


# -- MCAP -------------------------------------------------------------------------------------


def small_mcap(messages: int = 300) -> bytes:
    out = io.BytesIO()
    writer = Writer(out, compression=CompressionType.ZSTD, chunk_size=512)
    writer.start(profile="", library="abuse")
    channel = writer.register_channel("/n", "json", writer.register_schema("n", "jsonschema", b"{}"))
    for n in range(messages):
        writer.add_message(channel, n, b'{"n": %d}' % n, n)
    writer.finish()  # type: ignore[no-untyped-call]
    return out.getvalue()


GOOD = small_mcap()


@FAST
@given(
    flips=st.lists(st.tuples(st.integers(0, len(GOOD) - 1), st.integers(1, 255)), max_size=8),
    cut=st.integers(0, len(GOOD)),
    insert=st.tuples(st.integers(0, len(GOOD)), st.binary(max_size=64)),
)
def test_damaged_mcap_is_read_around_its_damage(flips: list[tuple[int, int]], cut: int,
                                                insert: tuple[int, bytes]) -> None:  # fmt: skip
    data = bytearray(GOOD)
    for at, mask in flips:
        data[at] ^= mask
    at, extra = insert
    data[at:at] = extra
    data = data[: max(cut, 8)]
    found = Salvage()

    def read() -> int:
        return sum(1 for _ in read_records(io.BytesIO(bytes(data)), SMALL, found))

    result, peak = peak_bytes(read)
    if isinstance(result, InputError):
        one_line(result)
    else:
        assert result <= 300 + 10
        assert all("\n" not in line for line in found.lost)
    assert peak < 16 * MIB


@FAST
@given(
    declared=st.integers(0, 1 << 62),
    payload=st.binary(max_size=256),
    compression=st.sampled_from(["zstd", "lz4", "", "gzip"]),
)
def test_chunk_headers_that_lie_cost_nothing(declared: int, payload: bytes, compression: str) -> None:  # fmt: skip
    name = compression.encode()
    body = struct.pack("<QQQI", 0, 0, declared, 0) + struct.pack("<I", len(name)) + name
    body += struct.pack("<Q", len(payload)) + payload
    data = b"\x89MCAP0\r\n" + b"\x06" + struct.pack("<Q", len(body)) + body
    found = Salvage()
    result, peak = peak_bytes(lambda: list(read_records(io.BytesIO(data), SMALL, found)))
    assert not isinstance(result, InputError) or "\n" not in str(result)
    assert peak < 8 * MIB
    assert found.decompressed <= SMALL.chunk * MIB


# -- backups ----------------------------------------------------------------------------------


@FAST
@given(document=st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=10), inner, max_size=5),
    max_leaves=30,
))  # fmt: skip
def test_backups_are_ours_or_one_line(tmp_path_factory: Any, document: Any) -> None:
    path: Path = tmp_path_factory.mktemp("backup") / "b.json"
    for variant in (document, {"format": "nurimc-backup/1", "motors": document}):
        path.write_text(json.dumps(variant), encoding="utf-8")
        try:
            load(path)
        except BackupError as error:
            one_line(error)
