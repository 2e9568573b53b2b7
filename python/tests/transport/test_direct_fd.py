"""SerialTransport writes and looks for waiting bytes on a POSIX port's descriptor directly
(docs/performance.md): the bytes are the same as through pyserial, and a closed transport never
touches the descriptor number again (another file may have it by then)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from nurimc.errors import PortError
from nurimc.transport import open_transport

pytestmark = pytest.mark.skipif(not hasattr(os, "openpty"), reason="needs a POSIX pty")


def test_the_direct_path_writes_reads_and_discards_the_same_bytes() -> None:
    master, slave = os.openpty()
    try:
        transport = open_transport(os.ttyname(slave), 115200)
        assert transport._direct is not None  # a pty is pyserial's own Serial class: the direct path
        transport.write(b"\xff\xfe\x01\x02\xfc\xa0")
        assert os.read(master, 64) == b"\xff\xfe\x01\x02\xfc\xa0"
        assert transport.discard_input() == b""
        os.write(master, b"stale")
        assert transport.read(5, 1.0) == b"stale"
        os.write(master, b"old bytes")
        deadline = time.monotonic() + 30  # the pty hands them over at once, or soon (a busy host: later)
        while not transport.discard_input():
            assert time.monotonic() < deadline, "the waiting bytes were never discarded"
            time.sleep(0.005)
        assert transport.read(1, 0.05) == b""
        transport.close()
    finally:
        os.close(master)
        os.close(slave)


def test_a_closed_transport_refuses_to_write_instead_of_writing_into_a_reused_descriptor(tmp_path: Path) -> None:
    master, slave = os.openpty()
    try:
        transport = open_transport(os.ttyname(slave), 115200)
        transport.close()
        victim = tmp_path / "another-file"
        fd = os.open(victim, os.O_CREAT | os.O_WRONLY)  # may well get the port's old number
        try:
            with pytest.raises(PortError):
                transport.write(b"\xff\xfe")
            with pytest.raises(PortError):
                transport.read(1, 0.01)
        finally:
            os.close(fd)
        assert victim.read_bytes() == b""
    finally:
        os.close(master)
        os.close(slave)
