"""Bus traffic from a logic analyzer, as traffic-log entries: what `nurimc replay` and
`nurimc record --mcap ... --from` read besides their own traffic logs.

Three kinds of file (told apart by their first bytes):
- the nurimc sigrok decoder's `log` binary output (`sigrok-cli ... -B nurimc=log`): already a
  traffic log (JSON lines), read by the traffic-log reader; `read_capture` returns None for it;
- both at once (`-B nurimc`: each frame's bytes, then its log line): the log lines are read;
- its `frames` binary output (`-B nurimc=frames`, starting FF FE, ID, a size byte of a
  message: a UTF-16 text's FF FE mark is not taken for it): whole frames back to back, no times (each
  entry gets t = 0) and no direction (a request or command is "tx", an answer "rx");
- a sigrok session file (`.sr`, a zip with `metadata` and `logic-1-*`; PulseView's "Save" or
  `sigrok-cli -o capture.sr`): every logic channel that toggles is read as an 8N1 UART line at
  the baud rate given or, by default, the table rate whose bit time is nearest the capture's
  short pulses; its frames (found by the stream parser, so noise is skipped as the libraries
  skip it) become entries with the time of their first start bit.
"""

from __future__ import annotations

import configparser
import itertools
import re
import zipfile
from collections import deque
from collections.abc import Iterator
from pathlib import Path

from ..budgets import MIB, ReadBudget, default_budget
from ..errors import InputError
from ..protocol import BAUD_RATES, BY_MODE, StreamParser

Entry = tuple[float, str, bytes]
HOST_KINDS = ("command", "request")
_MAX_SIZE = max(cls.SPEC.size for cls in BY_MODE.values())
_LOG_LINE = re.compile(rb'\{"t": ([0-9.e+-]+), "dir": "(tx|rx)", "hex": "((?:[0-9a-f]{2})+)"\}\n')
_UNITS = {"": 1, "k": 1_000, "m": 1_000_000, "g": 1_000_000_000}
GUESS_RUNS = 200_000  # pulses looked at to guess the baud rate (the first ones: plenty)
READ_BLOCK = 1 << 20


def read_capture(path: str | Path, baud: int | None = None, budget: ReadBudget | None = None) -> list[Entry] | None:
    """Entries of a sigrok capture or of the decoder's frames output; None for a traffic log.
    Bounded by `budget` (nurimc.budgets: samples, edges, probes, records); InputError, one line."""
    budget = budget or default_budget()
    try:
        with open(path, "rb") as file:
            head = file.read(4)
    except OSError as error:
        raise InputError(f"{path}: {error.strerror or error}") from None
    if head.startswith(b"PK\x03\x04"):
        return read_session(path, baud, budget)
    if head.startswith(b"\xff\xfe") and len(head) == 4 and 2 <= head[3] <= _MAX_SIZE:  # not a UTF-16 mark
        limit = budget.samples * MIB
        with open(path, "rb") as file:
            data = file.read(limit + 1)
        if len(data) > limit:
            raise budget.over(f"{path}: decoder output", budget.samples, " MiB")
        lines = _LOG_LINE.findall(data)
        if len(lines) > budget.records:
            raise budget.over(f"{path}: frames", budget.records)
        if lines:  # `-B nurimc` without a class: each frame's bytes, then its log line
            return [(float(t), way.decode(), bytes.fromhex(text.decode())) for t, way, text in lines]
        return read_frames(data, str(path))
    return None


def convert_to_mcap(source: str | Path, mcap_path: str | Path, baud: int | None = None) -> int:
    """Write every frame of a traffic log or capture to an MCAP file's /nurimc/frames topic, at
    its time in the log after the source file's modification time; returns the frame count."""
    from ..transport.trafficlog import read_traffic_log
    from .mcap_file import FRAMES_TOPIC, McapRecorder

    capture = read_capture(source, baud)
    entries = read_traffic_log(str(source)) if capture is None else capture
    start = Path(source).stat().st_mtime_ns
    recorder = McapRecorder(mcap_path)
    try:
        for t, way, data in entries:
            recorder.record(way, data, start + round(t * 1e9))
    finally:
        recorder.close()
    return recorder.counts.get(FRAMES_TOPIC, 0)


def direction(frame: bytes) -> str:
    """'tx' for what a host sends (commands, requests), 'rx' for answers."""
    return "tx" if BY_MODE[frame[5]].SPEC.kind in HOST_KINDS else "rx"


def read_frames(data: bytes, where: str) -> list[Entry]:
    """The decoder's `frames` output: every byte must belong to a whole frame."""
    parser = StreamParser()
    entries: list[Entry] = []
    at = 0
    for message in [*parser.feed(data), *parser.finish()]:
        length = message.SPEC.size + 4
        entries.append((0.0, direction(data[at : at + length]), data[at : at + length]))
        at += length
    if parser.stats.dropped_bytes:
        raise InputError(
            f"{where}: {parser.stats.dropped_bytes} byte(s) are not whole frames; "
            "expected the nurimc decoder's 'frames' output (sigrok-cli -B nurimc=frames)"
        )
    return entries


def _samplerate(text: str, where: str) -> int:
    match = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?)\s*([kKmMgG]?)\s*Hz\s*", text)
    rate = round(float(match.group(1)) * _UNITS[match.group(2).lower()]) if match else 0
    if not 1 <= rate <= 100_000_000_000:
        raise InputError(f"{where}: samplerate {text[:40]!r} is not a rate such as '1 MHz'")
    return rate


def _whole(section: configparser.SectionProxy, name: str, default: int, top: int, where: str) -> int:
    text = section.get(name, str(default))
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 1 <= value <= top:
        raise InputError(f"{where}: metadata {name} {text[:40]!r} is not a whole number 1..{top}")
    return value


def _read_parts(archive: zipfile.ZipFile, parts: list[str], limit: int, where: str, budget: ReadBudget) -> bytes:
    """The sample files, decompressed a block at a time: a zip bomb stops at the limit."""
    out = bytearray()
    for name in parts:
        with archive.open(name) as member:
            while block := member.read(READ_BLOCK):
                out += block
                if len(out) > limit:
                    raise budget.over(f"{where}: decompressed samples", budget.samples, " MiB")
    return bytes(out)


def read_session(path: str | Path, baud: int | None = None, budget: ReadBudget | None = None) -> list[Entry]:
    """Every frame on every toggling channel of a sigrok session file, in time order."""
    budget = budget or default_budget()
    where = str(path)
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
            if "metadata" not in names:
                raise InputError(f"{where}: a zip without 'metadata'; not a sigrok session file")
            meta = configparser.ConfigParser()
            meta.read_string(archive.read("metadata").decode("utf-8", "replace"))
            device = next((s for s in meta.sections() if s.startswith("device")), None)
            if device is None:
                raise InputError(f"{where}: metadata has no [device 1] section; not a logic capture")
            section = meta[device]
            prefix = section.get("capturefile", "logic-1")
            parts = sorted(
                (n for n in names if re.fullmatch(re.escape(prefix) + r"-\d+", n)),
                key=lambda n: int(n.rsplit("-", 1)[1]),
            )
            rate = _samplerate(section.get("samplerate", ""), where)
            probes = _whole(section, "total probes", 0, budget.probes, where)
            unitsize = _whole(section, "unitsize", 1, (budget.probes + 7) // 8, where)
            samples = _read_parts(archive, parts, budget.samples * MIB, where, budget)
    except InputError:
        raise
    except (zipfile.BadZipFile, configparser.Error, OSError, UnicodeError, EOFError, ValueError) as error:
        why = str(error).splitlines()[0][:200] if str(error) else type(error).__name__
        raise InputError(f"{where}: not a readable sigrok session file ({why})") from None
    if not samples:
        raise InputError(f"{where}: no logic samples (samplerate, unitsize and probes are needed)")
    lines: list[tuple[int, bytes]] = []
    edges = 0
    for channel in range(min(probes, 8 * unitsize)):
        levels = _channel(samples, unitsize, channel)
        if levels.find(b"\x00") < 0 or levels.find(b"\x01") < 0:
            continue  # a line that never toggles carries no bytes
        edges += levels.count(b"\x00\x01") + levels.count(b"\x01\x00")
        if edges > budget.edges:  # counted at C speed before any decoding in Python
            raise budget.over(f"{where}: signal edges", budget.edges)
        lines.append((channel, levels))
    del samples
    entries: list[Entry] = []
    while lines:
        _, levels = lines.pop(0)
        bit = rate / (baud or _guess_baud(levels, rate))
        entries += _frames(_uart_bytes(levels, bit), rate)
        if len(entries) > budget.records:
            raise budget.over(f"{where}: frames", budget.records)
    entries.sort(key=lambda e: e[0])
    return entries


def _channel(samples: bytes, unitsize: int, channel: int) -> bytes:
    """One channel's levels, one byte (0 or 1) per sample."""
    bit = channel % 8
    table = bytes((value >> bit) & 1 for value in range(256))
    return samples[channel // 8 :: unitsize].translate(table)


def _runs(levels: bytes, most: int = GUESS_RUNS) -> list[int]:
    """Lengths of the first `most` runs of equal level between edges (the first and last are left out)."""
    edges: list[int] = []
    pos, want = levels.find(b"\x00"), b"\x01"
    while pos >= 0 and len(edges) <= most:
        edges.append(pos)
        pos = levels.find(want, pos)
        want = b"\x00" if want == b"\x01" else b"\x01"
    return [b - a for a, b in itertools.pairwise(edges)]


def _guess_baud(levels: bytes, rate: int) -> int:
    """The table rate that explains most pulses as 1 to 9 whole bits (8N1 has no longer run of
    equal bits inside a byte); glitches, shorter than half a bit, and idle gaps explain nothing."""
    runs = _runs(levels)

    def explained(baud: int) -> int:
        bit = rate / baud
        count = 0
        for run in runs:
            bits = run / bit
            if 0.5 <= bits < 9.5 and abs(bits - round(bits)) < 0.2:
                count += 1
        return count

    best = max(BAUD_RATES, key=explained)
    if rate / best < 3 or explained(best) == 0:
        raise InputError(f"cannot tell the baud rate at {rate} samples/s; capture at 10x the baud rate or more")
    return best


def _uart_bytes(levels: bytes, bit: float) -> Iterator[tuple[int, int]]:
    """(first sample of the start bit, byte) of every 8N1 frame: sampled mid-bit, idle high; a
    start bit that is high at mid-bit (a glitch) or a low stop bit (framing error) is no byte."""
    n = len(levels)
    pos = levels.find(b"\x01")  # a line starts idle: wait for high first
    while pos >= 0:
        start = levels.find(b"\x00", pos)
        if start < 0 or start + 9.5 * bit >= n:
            break
        if levels[int(start + 0.5 * bit)] != 0:
            pos = start + 1
            continue
        value = 0
        for k in range(8):
            value |= levels[int(start + (1.5 + k) * bit)] << k
        stop = int(start + 9.5 * bit)
        if levels[stop] == 1:
            yield start, value
        pos = levels.find(b"\x01", stop)


def _frames(received: Iterator[tuple[int, int]], rate: int) -> list[Entry]:
    """Frames in one line's bytes by the stream parser, each with its first byte's time (only the
    last frame's worth of bytes is kept: memory does not grow with the capture)."""
    parser = StreamParser()
    recent: deque[tuple[int, int]] = deque(maxlen=_MAX_SIZE + 4)
    entries: list[Entry] = []
    for start, value in received:
        recent.append((start, value))
        for message in parser.feed(bytes((value,))):
            length = message.SPEC.size + 4
            tail = list(recent)[-length:]
            frame = bytes(v for _, v in tail)
            entries.append((round(tail[0][0] / rate, 6), direction(frame), frame))
    return entries
