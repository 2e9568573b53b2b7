"""Shared test helpers."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[2]


def load_vectors(name: str | None = None) -> list[dict[str, Any]]:
    files = (
        [ROOT / "spec" / "vectors" / f"{name}.jsonl"] if name else sorted((ROOT / "spec" / "vectors").glob("*.jsonl"))
    )
    return [json.loads(line) for path in files for line in path.read_text().splitlines() if line.strip()]


def pytest_configure(config: Any) -> None:
    config.addinivalue_line(
        "markers", "realtime: an end-to-end test on the real clock (generous bounds; the rest run on virtual time)"
    )


@pytest.fixture
def make_sim_bus() -> Iterator[Callable[..., tuple[Any, Any]]]:
    """Build (SimBus, Bus) pairs with tests.client.simfixtures.sim_bus; all closed afterwards."""
    from .client.simfixtures import sim_bus

    made: list[tuple[Any, Any]] = []

    def build(*args: Any, **kwargs: Any) -> tuple[Any, Any]:
        pair = sim_bus(*args, **kwargs)
        made.append(pair)
        return pair

    yield build
    for sim, bus in made:
        bus.close()
        sim.close()
