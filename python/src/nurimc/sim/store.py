"""Persistence: one JSON file per bus, written atomically, so settings survive a restart."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

STATE_FILE = "bus.json"
FORMAT_VERSION = 1


class StateError(Exception):
    """The state directory or file cannot be used."""


class StateStore:
    """Settings of every controller slot (the n-th controller added to the bus is slot n)."""

    def __init__(self, state_dir: str | os.PathLike[str]) -> None:
        self.directory = Path(state_dir)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StateError(f"cannot create the state directory {self.directory}: {exc}") from exc
        self.path = self.directory / STATE_FILE
        self._slots: list[dict[str, Any]] = self._load()

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
        return slots

    def slot(self, index: int) -> dict[str, Any] | None:
        """The stored record of slot `index` ({"product": .., "settings": {..}}), if any."""
        return self._slots[index] if index < len(self._slots) else None

    def save(self, records: list[dict[str, Any]]) -> None:
        """Store the first len(records) slots (later stored slots are kept), atomically: a crash
        leaves the old or the new file, never half of one."""
        self._slots = records + self._slots[len(records) :]
        text = json.dumps({"version": FORMAT_VERSION, "controllers": self._slots}, indent=1)
        fd, tmp = tempfile.mkstemp(dir=self.directory, prefix=".bus-", suffix=".tmp")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(text)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, self.path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
