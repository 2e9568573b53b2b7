"""Shared test helpers."""

from __future__ import annotations

import inspect
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


#: modules whose use makes a test real-time (processes, terminals, sockets): marked by rule, not by hand
REALTIME_MODULES = frozenset({"subprocess", "pty", "socket", "multiprocessing"})


def uses_real_time(module: Any) -> bool:
    """A test module that imports subprocess, pty or socket (or names from them) runs on real time."""
    for value in vars(module).values():
        name = getattr(value, "__name__", "") if inspect.ismodule(value) else getattr(value, "__module__", "")
        if isinstance(name, str) and name.split(".")[0] in REALTIME_MODULES:
            return True
    return False


def pytest_collection_modifyitems(config: Any, items: list[Any]) -> None:
    """Mark `realtime` every test of a module that uses processes, terminals or sockets (docs/architecture.md)."""
    seen: dict[str, bool] = {}
    for item in items:
        module = getattr(item, "module", None)
        if module is None:
            continue
        if module.__name__ not in seen:
            seen[module.__name__] = uses_real_time(module)
        if seen[module.__name__] and item.get_closest_marker("realtime") is None:
            item.add_marker(pytest.mark.realtime)


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
