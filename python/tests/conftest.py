"""Shared test helpers."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]


def load_vectors(name: str | None = None) -> list[dict[str, Any]]:
    files = (
        [ROOT / "spec" / "vectors" / f"{name}.jsonl"] if name else sorted((ROOT / "spec" / "vectors").glob("*.jsonl"))
    )
    return [json.loads(line) for path in files for line in path.read_text().splitlines() if line.strip()]
