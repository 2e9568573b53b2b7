"""Read what an MCAP file still holds, record by record, within a budget (issue 39, item 6).

The mcap library's readers stop at the first broken record and decompress a chunk whole (a
32 KB chunk can claim, or hold, gigabytes). Here the outer records are read one at a time by
their length; a chunk is decompressed a block at a time up to the budget's `chunk` MiB and its
CRC checked; a chunk that is broken, over the budget or fails its CRC is *skipped* and reported,
and reading goes on with the next record. When a length itself is broken (the next record is not
where it says), the file is searched forward for the next record that reads as a whole chunk.
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Footer, Header, McapRecord, Message, Schema

from ..budgets import MIB, ReadBudget, default_budget
from ..errors import InputError

MAGIC = b"\x89MCAP0\r\n"
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, DATA_END = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F
KNOWN_OPCODES = frozenset(range(0x01, 0x10))
COMPRESSIONS = ("", "zstd", "lz4")
SCAN_BLOCK = 1 << 20
_CHUNK_FIXED = 8 + 8 + 8 + 4 + 4  # start, end, uncompressed size, crc, compression length


@dataclass
class Salvage:
    """What a read found besides the records it yielded."""

    chunks: int = 0  # whole chunks read
    lost: list[str] = field(default_factory=list)  # one short line per chunk or stretch skipped
    skipped_bytes: int = 0
    torn_at: int | None = None  # the file ends in a record cut short (or unreadable bytes) here
    footer: bool = False
    decompressed: int = 0

    def summary(self, most: int = 3) -> str:
        shown = "; ".join(self.lost[:most])
        more = f"; and {len(self.lost) - most} more" if len(self.lost) > most else ""
        return f"{len(self.lost)} part(s) lost ({shown}{more})"


def read_records(
    stream: BinaryIO, budget: ReadBudget | None = None, found: Salvage | None = None
) -> Iterator[McapRecord]:
    """Header, Schema, Channel, Message (from chunks too) and Footer records of an MCAP stream
    (seekable), skipping what is broken; what was skipped is added to `found`. InputError (one
    line) if the stream is no MCAP file at all."""
    budget = budget or default_budget()
    found = found if found is not None else Salvage()
    if stream.read(len(MAGIC)) != MAGIC:
        raise InputError("not an MCAP file (its first bytes are not the MCAP magic)")
    end = stream.seek(0, io.SEEK_END)
    pos = stream.seek(len(MAGIC))
    while pos < end:
        stream.seek(pos)
        head = stream.read(9)
        if len(head) < 9:
            found.torn_at = pos
            return
        opcode, length = head[0], struct.unpack_from("<Q", head, 1)[0]
        if opcode not in KNOWN_OPCODES or length > end - pos - 9:
            where = pos
            pos = _next_chunk(stream, pos + 1, end)
            found.skipped_bytes += pos - where
            if pos >= end:  # nothing whole after it: the file is torn there
                found.torn_at = where
                return
            found.lost.append(f"bytes {where}..{pos} unreadable")
            continue
        if opcode == CHUNK and length > budget.chunk * MIB + 1024:
            found.lost.append(f"chunk at byte {pos}: {length:,} bytes compressed, over the {budget.chunk} MiB limit")
            found.skipped_bytes += 9 + length
            pos += 9 + length
            continue
        body = stream.read(length) if opcode in (HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK) else b""
        pos += 9 + length
        if opcode == CHUNK:
            try:
                records = _chunk_records(body, budget, found)
            except _Broken as error:
                found.lost.append(f"chunk at byte {pos - 9 - length}: {error}")
                found.skipped_bytes += 9 + length
                continue
            found.chunks += 1
            yield from records
        elif opcode in (HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE):
            try:
                record = _parse(opcode, body)
            except _Broken as error:
                found.lost.append(f"record at byte {pos - 9 - length}: {error}")
                continue
            if opcode == FOOTER:
                found.footer = True
                yield record
                return
            yield record
        elif opcode == DATA_END:
            continue


class _Broken(Exception):
    pass


def _parse(opcode: int, body: bytes) -> McapRecord:
    data = ReadDataStream(io.BytesIO(body))
    try:
        if opcode == MESSAGE:
            message: McapRecord = Message.read(data, len(body))
            return message
        record: McapRecord = {HEADER: Header, FOOTER: Footer, SCHEMA: Schema, CHANNEL: Channel}[opcode].read(data)  # type: ignore[attr-defined]
        return record
    except Exception as error:  # struct, UnicodeDecodeError, a short read: a malformed record
        raise _Broken(f"malformed ({type(error).__name__})") from None


def _chunk_header(body: bytes) -> tuple[int, int, str, int] | None:
    """(uncompressed size, crc, compression, offset of the records) if `body` is shaped as a chunk."""
    if len(body) < _CHUNK_FIXED + 8:
        return None
    size, crc, clen = struct.unpack_from("<QII", body, 16)
    if clen > 8 or len(body) < _CHUNK_FIXED + clen + 8:
        return None
    try:
        compression = body[_CHUNK_FIXED : _CHUNK_FIXED + clen].decode("ascii")
    except UnicodeDecodeError:
        return None
    (records_length,) = struct.unpack_from("<Q", body, _CHUNK_FIXED + clen)
    start = _CHUNK_FIXED + clen + 8
    if compression not in COMPRESSIONS or start + records_length != len(body):
        return None
    return size, crc, compression, start


def _decompress(compression: str, data: bytes, limit: int) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        import zstandard

        out = bytearray()
        with zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data)) as reader:
            while block := reader.read(SCAN_BLOCK):
                out += block
                if len(out) > limit:
                    break
        return bytes(out)
    import lz4.frame  # type: ignore[import-untyped]

    decompressor = lz4.frame.LZ4FrameDecompressor()
    result: bytes = decompressor.decompress(data, max_length=limit + 1)
    return result


def _chunk_records(body: bytes, budget: ReadBudget, found: Salvage) -> list[McapRecord]:
    shape = _chunk_header(body)
    if shape is None:
        raise _Broken("not shaped as a chunk")
    size, crc, compression, start = shape
    limit = budget.chunk * MIB
    if size > limit:
        raise _Broken(f"declares {size:,} bytes decompressed, over the {budget.chunk} MiB limit")
    if found.decompressed + size > budget.decompressed * MIB:
        raise budget.over("the chunks decompressed in all", budget.decompressed, " MiB")
    try:
        data = _decompress(compression, body[start:], size)
    except Exception as error:  # zstd/lz4 errors on damaged data
        raise _Broken(f"does not decompress ({type(error).__name__})") from None
    if len(data) != size:
        raise _Broken(f"decompresses to other than its declared {size:,} bytes")
    if crc and zlib.crc32(data) != crc:
        raise _Broken("CRC mismatch")
    found.decompressed += size
    records: list[McapRecord] = []
    at = 0
    while at + 9 <= len(data):
        opcode, length = data[at], struct.unpack_from("<Q", data, at + 1)[0]
        if at + 9 + length > len(data):
            raise _Broken("a record inside runs past its end")
        if opcode in (SCHEMA, CHANNEL, MESSAGE):
            records.append(_parse(opcode, data[at + 9 : at + 9 + length]))
        at += 9 + length
    return records


def _next_chunk(stream: BinaryIO, pos: int, end: int) -> int:
    """The offset of the next record from `pos` that reads as a whole chunk (or `end`)."""
    while pos < end:
        stream.seek(pos)
        window = stream.read(SCAN_BLOCK + 9)
        at = window.find(bytes((CHUNK,)))
        while at >= 0 and at < SCAN_BLOCK:
            if _whole_chunk_at(stream, pos + at, end):
                return pos + at
            at = window.find(bytes((CHUNK,)), at + 1)
        pos += SCAN_BLOCK
    return end


def _whole_chunk_at(stream: BinaryIO, pos: int, end: int) -> bool:
    stream.seek(pos)
    head = stream.read(9 + _CHUNK_FIXED + 8 + 8)
    if len(head) < 9 or head[0] != CHUNK:
        return False
    (length,) = struct.unpack_from("<Q", head, 1)
    if length > end - pos - 9 or length < _CHUNK_FIXED + 8:
        return False
    _size, _crc, clen = struct.unpack_from("<QII", head, 9 + 16)
    if clen > 8 or len(head) < 9 + _CHUNK_FIXED + clen + 8:
        return False
    (records_length,) = struct.unpack_from("<Q", head, 9 + _CHUNK_FIXED + clen)
    return bool(_CHUNK_FIXED + clen + 8 + records_length == length)
