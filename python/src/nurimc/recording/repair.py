"""Repair a torn MCAP file: keep every whole record up to the tear, write a complete file.

Our recorder's files are complete at every checkpoint (recording/checkpoint.py), so a torn one
comes from a crash in the middle of a checkpoint's write, a power loss before the disk got it,
another program's recording, or a copy cut short. `nurimc repair-mcap` reads records in order
until the first one that is not whole (a cut record, a chunk whose CRC fails), and writes
every schema, channel and message before it into a new file with its index.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mcap.records import Channel, Footer, Header, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer


@dataclass
class Repaired:
    messages: int
    complete: bool  # the input had its footer: nothing was lost
    problem: str  # what ended the reading ("" if the input was complete)


def repair(source: str | Path, target: str | Path) -> Repaired:
    """Copy what `source` holds up to its first broken record into `target`, a complete file.

    Raises ValueError (one line) if `source` cannot be read or is no MCAP file at all."""
    source, target = Path(source), Path(target)
    if source.resolve() == target.resolve():
        raise ValueError(f"{target}: write the repaired file to another path than the torn one")
    try:
        stream = source.open("rb")
    except OSError as error:
        raise ValueError(f"cannot read {source}: {error.strerror or error}") from None
    with stream:
        try:
            out = target.open("wb")
        except OSError as error:
            raise ValueError(f"cannot write {target}: {error.strerror or error}") from None
        with out:
            writer = Writer(out, compression=CompressionType.ZSTD)
            result = _copy(StreamReader(stream, validate_crcs=True), writer, source)
            writer.finish()  # type: ignore[no-untyped-call]
    return result


def _copy(reader: StreamReader, writer: Writer, source: Path) -> Repaired:
    schemas: dict[int, int] = {}  # id in the source -> id in the target
    channels: dict[int, int] = {}
    count, started = 0, False
    records = reader.records
    while True:
        try:
            record = next(records)
        except StopIteration:
            return Repaired(count, False, "the file ends without its footer")
        except Exception as error:  # a cut record fails in the reader, struct or the decompressor
            why = str(error) or type(error).__name__
            if not started:
                raise ValueError(f"{source} is not an MCAP file ({why})") from None
            return Repaired(count, False, f"a record cut short or broken after {count} messages ({why})")
        if isinstance(record, Header):
            writer.start(profile=record.profile, library=record.library)
            started = True
        elif isinstance(record, Schema) and record.id not in schemas:
            schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
        elif isinstance(record, Channel) and record.id not in channels:
            channels[record.id] = writer.register_channel(
                record.topic, record.message_encoding, schemas.get(record.schema_id, 0), record.metadata
            )
        elif isinstance(record, Message) and record.channel_id in channels:
            writer.add_message(channels[record.channel_id], record.log_time, record.data, record.publish_time)
            count += 1
        elif isinstance(record, Footer):
            return Repaired(count, True, "")
