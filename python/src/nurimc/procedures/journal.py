"""The restore journal: a restore that was interrupted is found on the next run.

A controller has no spare setting to hold a marker and takes every write to EEPROM, so the
marker lives on the host, in the user's state directory: one small file per port and
controller ID, written (atomically, synced) before the first setting is written and removed
once every setting of the backup is confirmed on that controller. A journal left behind means
the restore of its file did not finish: `status` and `restore` say "incomplete restore of
FILE: run restore again", and running it again writes what still differs (docs/library.md,
Restore journal).

The directory: `$NURIMC_STATE_DIR`, else `$XDG_STATE_HOME/nurimc`, else `~/.local/state/nurimc`;
journals in its `restore/`. The port is keyed as given (`/dev/serial/by-id/…` and the
`/dev/ttyUSB0` it points to are two keys: give the port the same way each time).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Iterable
from pathlib import Path

from .backup import write_atomic


def state_dir() -> Path:
    explicit = os.environ.get("NURIMC_STATE_DIR")
    if explicit:
        return Path(explicit)
    xdg = os.environ.get("XDG_STATE_HOME")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "state"
    return base / "nurimc"


class RestoreJournal:
    """Journals of restores under way on one port."""

    def __init__(self, port: str, directory: str | os.PathLike[str] | None = None) -> None:
        self.port = port
        self.directory = Path(directory) if directory is not None else state_dir() / "restore"
        # A sim:// URL without state= is a new bus each time it is opened: nothing to come back to.
        self.enabled = bool(port) and not (port.startswith("sim://") and "state=" not in port)

    def _path(self, device_id: int) -> Path:
        key = hashlib.sha256(self.port.encode("utf-8", "surrogateescape")).hexdigest()[:16]
        return self.directory / f"{key}-id{device_id}.json"

    def pending(self, device_id: int) -> str | None:
        """The backup file whose restore to this ID did not finish, or None."""
        if not self.enabled:
            return None
        try:
            entry = json.loads(self._path(device_id).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None  # none (or a journal we cannot read: nothing to say about it)
        if not isinstance(entry, dict) or entry.get("port") != self.port or not isinstance(entry.get("file"), str):
            return None
        return str(entry["file"])

    def begin(self, device_ids: Iterable[int], file: str | os.PathLike[str]) -> None:
        """Before the first write: mark each ID as being restored from `file`."""
        if not self.enabled:
            return
        self.directory.mkdir(parents=True, exist_ok=True)
        started = time.strftime("%Y-%m-%dT%H:%M:%S")
        for device_id in device_ids:
            entry = {"port": self.port, "id": device_id, "file": str(Path(file).resolve()), "started": started}
            write_atomic(self._path(device_id), json.dumps(entry) + "\n")

    def done(self, device_ids: Iterable[int]) -> None:
        """Every setting of the backup is confirmed on these IDs."""
        for device_id in device_ids:
            self._path(device_id).unlink(missing_ok=True)


def incomplete_message(file: str) -> str:
    return f"incomplete restore of {file}: run restore again"
