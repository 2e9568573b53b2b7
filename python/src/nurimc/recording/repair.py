"""Repair a torn or damaged MCAP file: keep every whole record, write a complete file.

Our recorder's files are complete at every checkpoint (recording/checkpoint.py), so a torn one
comes from a crash in the middle of a checkpoint's write, a power loss before the disk got it,
another program's recording, or a copy cut short. `nurimc repair-mcap` reads the records in
order (recording/salvage.py): a broken chunk (a bit flip, a CRC that fails, a chunk over the
read budget) is skipped and reported, and the repair goes on with the next good chunk; every
schema, channel and message read is written into a new file with its index.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Footer, Header, Message, Schema
from mcap.writer import CompressionType, Writer

from ..budgets import ReadBudget
from ..errors import InputError
from .salvage import Salvage, read_records


@dataclass
class Repaired:
    messages: int
    complete: bool  # the input had its footer and nothing was skipped: nothing was lost
    problem: str  # what was lost or ended the reading ("" if the input was complete)
    lost: list[str] = field(default_factory=list)  # one line per part skipped


def repair(source: str | Path, target: str | Path, budget: ReadBudget | None = None) -> Repaired:
    """Copy what `source` still holds into `target`, a complete file.

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
            try:
                result = _copy(stream, writer, source, budget)
            finally:
                writer.finish()  # type: ignore[no-untyped-call]
    return result


def _copy(stream: object, writer: Writer, source: Path, budget: ReadBudget | None) -> Repaired:
    schemas: dict[int, int] = {}  # id in the source -> id in the target
    channels: dict[int, int] = {}
    count, started = 0, False
    found = Salvage()
    try:
        for record in read_records(stream, budget, found):  # type: ignore[arg-type]
            if isinstance(record, Header) and not started:
                writer.start(profile=record.profile, library=record.library)
                started = True
                continue
            if not started:  # a file whose header is lost still has its messages
                writer.start(profile="", library="nurimc repair-mcap")
                started = True
            if isinstance(record, Schema) and record.id not in schemas:
                schemas[record.id] = writer.register_schema(record.name, record.encoding, record.data)
            elif isinstance(record, Channel) and record.id not in channels:
                channels[record.id] = writer.register_channel(
                    record.topic, record.message_encoding, schemas.get(record.schema_id, 0), record.metadata
                )
            elif isinstance(record, Message) and record.channel_id in channels:
                writer.add_message(channels[record.channel_id], record.log_time, record.data, record.publish_time)
                count += 1
            elif isinstance(record, Footer):
                break
    except InputError as error:
        if not started:
            why = str(error).removeprefix("not an MCAP file (").removesuffix(")")
            raise ValueError(f"{source} is not an MCAP file ({why})") from None
        found.lost.append(str(error))
    if not started:
        writer.start(profile="", library="nurimc repair-mcap")
    if found.footer and not found.lost:
        return Repaired(count, True, "")
    ending = (
        f"a record cut short at byte {found.torn_at}" if found.torn_at is not None else "the end without its footer"
    )
    if not found.lost:
        return Repaired(count, False, f"{ending} after {count} messages")
    problem = f"{found.summary()}; {ending}" if not found.footer else found.summary()
    return Repaired(count, False, problem, list(found.lost))
