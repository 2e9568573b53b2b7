"""Persistence: one JSON file per bus, written atomically, so settings survive a restart.

Rules (docs/simulator.md, Persistence):
- the file is checked whole on load; a bad entry is refused with one line naming the file,
  the slot and the field (a wrong value must not surface later as a crash in the physics);
- one simulator at a time owns a state directory (an flock on DIR/bus.lock, released by the
  kernel however the process ends), so a second one is refused instead of racing the first;
- a write goes to a uniquely named temporary file that is fsynced and renamed over bus.json
  before the write counts as done, and the temporary file is removed in `finally`; one left by
  a killed simulator is removed when the next one takes the directory.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import tempfile
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..protocol import PRODUCTS
from .settings import stored_problem

STATE_FILE = "bus.json"
LOCK_FILE = "bus.lock"
TMP_PREFIX, TMP_SUFFIX = ".bus-", ".tmp"
FORMAT_VERSION = 1


class StateError(InputError):
    """The state directory or file cannot be used."""


class StateStore:
    """Settings of every controller slot (the n-th controller added to the bus is slot n)."""

    def __init__(self, state_dir: str | os.PathLike[str]) -> None:
        self.directory = Path(state_dir)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            self._lock_fd: int | None = os.open(self.directory / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise StateError(f"cannot use the state directory {self.directory}: {exc.strerror or exc}") from exc
        try:
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self.close()
            raise StateError(
                f"the state directory {self.directory} is in use by another running simulator; "
                "stop it or choose another --state directory"
            ) from None
        self._remove_stale_temporaries()
        self.path = self.directory / STATE_FILE
        try:
            self._slots: list[dict[str, Any]] = self._load()
        except StateError:
            self.close()
            raise

    def _remove_stale_temporaries(self) -> None:
        """Temporary files of a simulator killed mid-write (we hold the lock: nobody else writes)."""
        for stale in self.directory.glob(f"{TMP_PREFIX}*{TMP_SUFFIX}"):
            with contextlib.suppress(OSError):
                stale.unlink()

    def _load(self) -> list[dict[str, Any]]:
        if not self.path.exists():
            return []
        try:
            data = json.loads(self.path.read_text())
        except (OSError, ValueError) as exc:
            raise StateError(
                f"cannot read the simulator state {self.path}: {exc}; delete the file to start from factory settings"
            ) from exc
        slots = data.get("controllers") if isinstance(data, dict) else None
        if not isinstance(slots, list) or not all(isinstance(s, dict) for s in slots):
            raise StateError(
                f"{self.path} is not a simulator state file (no 'controllers' list); delete it or "
                "choose another --state directory"
            )
        if data.get("version") != FORMAT_VERSION:
            raise StateError(f"{self.path}: 'version' is {data.get('version')!r}; this simulator reads version 1")
        for index, slot in enumerate(slots):
            product = slot.get("product")
            if product not in PRODUCTS:
                problem: str | None = f"'product' is {product!r}; use one of {', '.join(PRODUCTS)}"
            else:
                problem = stored_problem(slot.get("settings"))
            if problem is not None:
                raise StateError(f"{self.path}: controller slot {index}: {problem}")
        return slots

    def slot(self, index: int) -> dict[str, Any] | None:
        """The stored record of slot `index` ({"product": .., "settings": {..}}), if any."""
        return self._slots[index] if index < len(self._slots) else None

    def save(self, records: list[dict[str, Any]]) -> None:
        """Store the first len(records) slots (later stored slots are kept), atomically: a crash
        leaves the old or the new file, never half of one. When this returns the new file is
        in place (fsynced and renamed), so whatever acknowledges the write may go ahead."""
        self._slots = records + self._slots[len(records) :]
        text = json.dumps({"version": FORMAT_VERSION, "controllers": self._slots}, indent=1)
        fd, tmp = tempfile.mkstemp(dir=self.directory, prefix=TMP_PREFIX, suffix=TMP_SUFFIX)
        try:
            with os.fdopen(fd, "w") as f:
                f.write(text)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, self.path)
        finally:
            Path(tmp).unlink(missing_ok=True)  # gone already after the rename

    def close(self) -> None:
        """Release the directory (the kernel does the same if the process dies)."""
        if self._lock_fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._lock_fd)
            self._lock_fd = None
