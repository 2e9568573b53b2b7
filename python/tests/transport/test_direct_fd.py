"""SerialTransport writes and looks for waiting bytes on a POSIX port's descriptor directly
(docs/performance.md): the bytes are the same as through pyserial, and a closed transport never
touches the descriptor number again (another file may have it by then). A size read steadily
sets the terminal's VMIN so that select() wakes once the whole of it has come."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest

from nurimc.errors import PortError
from nurimc.transport import open_transport
from nurimc.transport.serial_transport import STEADY

termios = pytest.importorskip("termios")

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


def vmin(fd: int) -> int:
    return int(termios.tcgetattr(fd)[6][termios.VMIN])


def test_a_size_read_steadily_wakes_the_reader_once_it_has_all_come_and_any_other_size_undoes_it() -> None:
    master, slave = os.openpty()
    try:
        transport = open_transport(os.ttyname(slave), 115200)
        fd = transport._direct
        assert fd is not None
        for _ in range(STEADY):  # a polling loop: the same answer size again and again
            os.write(master, b"twelve bytes")
            assert transport.read(12, 5.0) == b"twelve bytes"
        assert vmin(fd) == 12  # select() now waits for the whole answer (one wake-up, not one a piece)
        os.write(master, b"twelve")  # half of it now, the rest a moment later: one read gets it all
        threading.Timer(0.05, os.write, (master, b" bytes")).start()
        assert transport.read(12, 5.0) == b"twelve bytes"
        os.write(master, b"short")  # never all of it: what came is there at the deadline
        started = time.monotonic()
        assert transport.read(12, 0.2) == b"short"
        assert time.monotonic() - started >= 0.2
        os.write(master, b"stale")  # a discard while VMIN is 12 takes what waits, without waiting
        deadline = time.monotonic() + 30
        while not (stale := transport.discard_input()):
            assert time.monotonic() < deadline, "the waiting bytes were never discarded"
            time.sleep(0.005)
        assert stale == b"stale"
        os.write(master, b"ping!!")  # another size: VMIN back to 0 at once (never above what a read needs)
        assert transport.read(6, 5.0) == b"ping!!"
        assert vmin(fd) == 0
        for _ in range(STEADY):
            os.write(master, b"twelve bytes")
            assert transport.read(12, 5.0) == b"twelve bytes"
        transport.baudrate = 57600  # pyserial writes its own termios (VMIN 0): set again on the next reads
        assert vmin(fd) == 0
        for _ in range(STEADY):
            os.write(master, b"twelve bytes")
            assert transport.read(12, 5.0) == b"twelve bytes"
        assert vmin(fd) == 12
        # the same rate again: pyserial writes nothing then (its VMIN 0 included), ours stays; a
        # read of another size must still see its bytes at once, not wait for 12 to its deadline
        transport.baudrate = 57600
        os.write(master, b"ping!!")
        started = time.monotonic()
        assert transport.read(6, 2.0) == b"ping!!"
        assert time.monotonic() - started < 1.0 and vmin(fd) == 0
        transport.close()
    finally:
        os.close(master)
        os.close(slave)


def test_where_select_does_not_wait_for_vmin_bytes_a_read_still_returns_the_whole_size(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import fcntl
    import select
    import struct

    def any_byte_select(
        r: list[int], w: list[int], x: list[int], timeout: float
    ) -> tuple[list[int], list[int], list[int]]:
        end = time.monotonic() + timeout  # readable as soon as one byte waits (VMIN ignored)
        while True:
            waiting = struct.unpack("I", fcntl.ioctl(r[0], termios.FIONREAD, b"\0\0\0\0"))[0]
            if waiting or time.monotonic() >= end:
                return (r if waiting else []), [], []
            time.sleep(0.001)

    master, slave = os.openpty()
    try:
        transport = open_transport(os.ttyname(slave), 115200)
        for _ in range(STEADY):
            os.write(master, b"twelve bytes")
            assert transport.read(12, 5.0) == b"twelve bytes"
        monkeypatch.setattr(select, "select", any_byte_select)
        os.write(master, b"twelve")
        threading.Timer(0.05, os.write, (master, b" bytes")).start()
        assert transport.read(12, 5.0) == b"twelve bytes"  # not the first piece alone
        os.write(master, b"short")
        assert transport.read(12, 0.2) == b"short"  # and what came, at the deadline
        transport.close()
    finally:
        os.close(master)
        os.close(slave)


def test_a_port_gone_when_vmin_is_set_is_a_port_error() -> None:
    master, slave = os.openpty()
    transport = open_transport(os.ttyname(slave), 115200)
    try:
        for _ in range(STEADY - 1):
            os.write(master, b"twelve bytes")
            assert transport.read(12, 5.0) == b"twelve bytes"
        os.close(master)  # the adapter unplugged: the next read sets VMIN on a terminal that is gone
        master = -1
        with pytest.raises(PortError):
            transport.read(12, 0.5)
    finally:
        transport.close()
        os.close(slave)
        if master >= 0:
            os.close(master)
