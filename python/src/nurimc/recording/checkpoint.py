"""An MCAP file that is complete on disk after every checkpoint, so a crash loses at most the
last interval (docs/cli.md, "Recordings survive a crash").

The MCAP writer buffers a chunk in memory and writes records to a stream; this stream keeps
them in memory too. A checkpoint finishes the chunk in progress, lets the writer write its
summary and footer as if the file ended there, and puts data and tail into the file in one
`pwrite` at the end of the data already there: the file on disk is always either the last
complete file or (while that one write runs) the same data with a longer tail being written.
The next checkpoint writes its data over the old tail. `kill -9` between checkpoints leaves
a complete, indexed file that every MCAP reader and rosbags open as it is.

A write that fails (the disk is full: ENOSPC, often after part of it went in) has written over
the start of the old tail: the old tail is written back where it was and the file cut to its
old end, which needs no new space (those blocks are the file's already), so the file is again
the complete file of the last checkpoint (`CheckpointFailed` says whether that worked).
"""

from __future__ import annotations

import os
from typing import Any

from mcap.writer import Writer

# The writer's summary-offset list (name-mangled private state, mcap 1.x): `finish()` appends to
# it, so a provisional tail must take its entries back out or the next tail lists them twice.
_SUMMARY_OFFSETS = "_Writer__summary_offsets"


class CheckpointFailed(OSError):
    """A checkpoint could not be written; `restored`: the file is the last checkpoint's again."""

    def __init__(self, error: OSError, restored: bool) -> None:
        super().__init__(error.errno, error.strerror or str(error))
        self.restored = restored


class CheckpointStream:
    """The writer's output: bytes held in memory until `commit`, which writes them at `offset`."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.committed = 0  # bytes of the data section already in the file
        self.pending = bytearray()
        self.end = 0  # where the file ends now (data + the last tail)
        self.tail = b""  # the last tail written (at `committed`): written back if a commit fails

    # what mcap.writer.Writer calls
    def write(self, data: bytes | bytearray | memoryview) -> int:
        self.pending += data
        return len(data)

    def tell(self) -> int:
        return self.committed + len(self.pending)

    def flush(self) -> None:
        """Nothing: bytes reach the file only at a checkpoint (a half-written tail is what we avoid)."""

    def commit(self, data_length: int) -> None:
        """Write everything pending in one call; the first `data_length` bytes stay, the rest
        (the provisional tail) is written over by the next commit."""
        data = bytes(self.pending)
        try:
            _write_at(self.fd, data, self.committed)
        except OSError as error:
            raise CheckpointFailed(error, self._restore()) from None
        end = self.committed + len(data)
        if end < self.end:  # never expected (tails only grow), but a longer old tail must not remain
            os.ftruncate(self.fd, end)
        self.end = end
        self.tail = data[data_length:]
        self.committed += data_length
        self.pending.clear()

    def _restore(self) -> bool:
        """The old tail back over what the failed write changed, the file cut to its old end."""
        try:
            _write_at(self.fd, self.tail, self.committed)
            os.ftruncate(self.fd, self.end)
            return True
        except OSError:
            return False


def _write_at(fd: int, data: bytes, offset: int) -> None:
    written = 0
    while written < len(data):  # a regular file takes it in one call; loop for the odd short write
        written += os.pwrite(fd, data[written:], offset + written)


def checkpoint(writer: Writer, stream: CheckpointStream, sync: bool = True) -> None:
    """Close the chunk in progress and make the file on disk complete up to here."""
    writer.flush()  # type: ignore[no-untyped-call]  # finishes the chunk into the stream's memory
    data_length = len(stream.pending)
    offsets: list[Any] = getattr(writer, _SUMMARY_OFFSETS)
    kept = len(offsets)
    writer.finish()  # type: ignore[no-untyped-call]  # DataEnd, summary, footer, magic: the provisional tail
    del offsets[kept:]
    stream.commit(data_length)
    if sync:
        os.fsync(stream.fd)


def finish(writer: Writer, stream: CheckpointStream) -> None:
    """The real end of the file: the last chunk, the summary and footer, synced."""
    writer.finish()  # type: ignore[no-untyped-call]
    stream.commit(len(stream.pending))
    os.fsync(stream.fd)
