"""kill -9 at any moment never loses an acknowledged settings write (--state).

A host writes ever larger rated speeds to a simulator running as its own process and counts a
write as acknowledged once it reads the value back; the simulator is killed with SIGKILL at a
random moment. After a restart on the same state directory the stored value must be the last
acknowledged one or the one written after it (sent, not yet confirmed), the file must load,
and no temporary file may be left over.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import serial

from .wirehelp import ask, command, u16

# a `nurimc sim` process killed with SIGKILL: end to end, on the real clock
pytestmark = pytest.mark.realtime

TRIALS = 6


def _start(state: Path) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "nurimc.sim", "--tcp", "0", "--ids", "1", "--state", str(state), "--eeprom-ms", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("ready: "):
            return proc, line.removeprefix("ready: ").strip()
    proc.wait(timeout=60)
    raise AssertionError(f"simulator did not start: {proc.stderr.read() if proc.stderr else ''}")


def _write_until_killed(address: str, first: int) -> tuple[int | None, int | None]:
    """Write rated speeds first, first+1, ... until the simulator dies; return (last acknowledged,
    last sent)."""
    acknowledged: int | None = None
    sent: int | None = None
    try:
        with serial.serial_for_url(f"socket://{address}", timeout=0.2) as port:
            value = first
            while True:
                sent = value
                command(port, 1, "set_rated_speed", u16(value))
                time.sleep(0.003)  # the EEPROM window (--eeprom-ms 2): a read-back inside it is ignored
                if ask(port, 1, 0xA6, patience=0.5) != u16(value):
                    return acknowledged, sent  # no read-back: the simulator is gone
                acknowledged = value
                value += 1
    except (serial.SerialException, OSError):
        return acknowledged, sent


def test_kill_9_never_loses_an_acknowledged_write(tmp_path: Path) -> None:
    rng = random.Random(9)
    next_value = 1000
    stored_before = 3000  # the factory rated speed
    acknowledged_writes = 0
    for trial in range(TRIALS):
        proc, address = _start(tmp_path)
        killer = threading.Timer(rng.uniform(0.1, 0.8), lambda p=proc: p.send_signal(signal.SIGKILL))
        killer.start()
        acknowledged, sent = _write_until_killed(address, next_value)
        killer.join()
        proc.wait(timeout=60)
        proc.communicate(timeout=60)
        assert proc.returncode == -signal.SIGKILL
        if acknowledged is not None:
            acknowledged_writes += acknowledged - next_value + 1
        else:  # killed before the first read-back: what was stored before still counts
            acknowledged = stored_before

        proc, address = _start(tmp_path)  # the same state directory: must load and hold the writes
        try:
            assert not list(tmp_path.glob(".bus-*.tmp")), "a temporary file outlived the restart"
            with serial.serial_for_url(f"socket://{address}", timeout=0.2) as port:
                stored = ask(port, 1, 0xA6)
            assert stored is not None
            value = int.from_bytes(stored, "big")
            assert value in (acknowledged, sent), f"trial {trial}: stored {value}, acknowledged {acknowledged}"
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.communicate(timeout=60)
        stored_before = value
        next_value = (sent or next_value) + 1
    assert acknowledged_writes >= 20, "too few writes were acknowledged for the trials to mean anything"
