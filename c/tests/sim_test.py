#!/usr/bin/env python3
"""Start the simulator on a pseudo-terminal, run test_sim against it, stop the simulator.

Usage: sim_test.py TEST_SIM_EXECUTABLE [PYTHON]   (PYTHON: the project venv's interpreter)
"""

from __future__ import annotations

import os
import selectors
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BAUD = "115200"


def wait_ready(proc: subprocess.Popen[bytes], timeout: float) -> str:
    """The path of the simulator's `ready: <path>` line, or an error with what it printed."""
    assert proc.stdout is not None
    fd = proc.stdout.fileno()
    sel = selectors.DefaultSelector()
    sel.register(fd, selectors.EVENT_READ)
    seen = b""
    while sel.select(timeout):
        chunk = os.read(fd, 4096)  # raw reads: a buffered reader would hide lines from select
        if not chunk:
            break
        seen += chunk
        for line in seen.decode(errors="replace").splitlines():
            if line.startswith("ready:"):
                return line.split(":", 1)[1].strip()
    raise SystemExit(f"simulator did not print 'ready:' within {timeout} s; it printed: {seen!r}")


def main(exe: str, python: str) -> int:
    with tempfile.TemporaryDirectory() as tmp:
        link = os.path.join(tmp, "ttySIM")
        cmd = [python, "-m", "nurimc.sim", "--link", link, "--ids", "0,1", "--baud", BAUD, "--echo"]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, cwd=ROOT)
        try:
            wait_ready(proc, 60)
            return subprocess.run([exe, link, BAUD], timeout=120).returncode
        finally:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else str(ROOT / ".venv" / "bin" / "python")))
