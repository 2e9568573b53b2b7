"""spec/vectors/backup-files.json: what a backup reader accepts and refuses, as the TypeScript library."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from nurimc.procedures import backup

VECTORS = Path(__file__).resolve().parents[3] / "spec" / "vectors" / "backup-files.json"
CASES: list[dict[str, Any]] = json.loads(VECTORS.read_text(encoding="utf-8"))["cases"]


@pytest.mark.parametrize("case", CASES, ids=lambda case: str(case["name"]))
def test_the_shared_backup_file_vectors(case: dict[str, Any], tmp_path: Path) -> None:
    def read() -> dict[str, Any]:
        if "text" in case:
            path = tmp_path / "robot.json"
            path.write_text(case["text"], encoding="utf-8")
            return backup.load(path)
        return backup.check(case["document"], "robot.json")

    if case.get("ok"):
        assert read()["format"] == backup.FORMAT
        return
    with pytest.raises(backup.BackupError) as refused:
        read()
    message = str(refused.value)
    assert case["error"] in message and "robot.json" in message and "\n" not in message
