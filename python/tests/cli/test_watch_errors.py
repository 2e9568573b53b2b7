"""`watch` shows a motor's whole error, cause included (issue 21: it was cut at 40 characters)."""

from __future__ import annotations

import os
import subprocess

from .test_cli import NURIMC


def test_watch_shows_the_whole_error() -> None:
    proc = subprocess.run(
        [NURIMC, "--port", "sim://?ids=1", "--id", "1,5", "watch", "--count", "2"],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, "COLUMNS": "400", "NO_COLOR": "1"},
    )
    assert proc.returncode == 0, proc.stderr
    shown = " ".join(proc.stdout.split())
    assert "no answer from ID 5 to request_position" in shown
    assert "Likely causes: the controller is at another baud rate" in shown  # the cause, not a cut
    assert "unpowered or busy writing its settings" in shown  # to the end
