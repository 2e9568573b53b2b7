"""docs/architecture.md's layer table is the truth: every module of python/src/nurimc is in one
layer, and every import points to its own layer or one below (never up).

The import graph is the one tests/test_imports.py reads from the source (every import counts:
deferred, under `if TYPE_CHECKING:`, lazy `import_module`)."""

from __future__ import annotations

import re

from .conftest import ROOT
from .test_imports import import_graph

DOC = ROOT / "docs" / "architecture.md"


def layers() -> dict[str, int]:
    """Module name prefix -> layer number, from the doc's machine-read table."""
    out: dict[str, int] = {}
    for line in DOC.read_text(encoding="utf-8").splitlines():
        row = re.match(r"\|\s*(\d+)\s[^|]*\|(.*)\|\s*$", line)
        if row:
            for name in re.findall(r"`([\w.]+)`", row.group(2)):
                assert name not in out, f"{name} is in two layers of docs/architecture.md"
                out[name] = int(row.group(1))
    return out


def layer_of(module: str, table: dict[str, int]) -> int | None:
    matches = [p for p in table if module == p or module.startswith(p + ".")]
    return table[max(matches, key=len)] if matches else None


def test_the_table_is_read() -> None:
    table = layers()
    assert table["nurimc.protocol"] == 0 and table["nurimc.client.core"] == 3 and table["nurimc.client"] == 5
    assert layer_of("nurimc.client.core", table) == 3 and layer_of("nurimc.client.aio", table) == 5
    assert layer_of("nurimc.protocol.units", table) == 0 and layer_of("nurimc.sim.bus", table) == 6


def test_every_module_has_a_layer_and_every_import_points_down() -> None:
    table = layers()
    graph = import_graph()
    unplaced = sorted(m for m in graph if layer_of(m, table) is None)
    assert not unplaced, f"modules in no layer of docs/architecture.md: {unplaced}"
    upward = []
    for module, targets in sorted(graph.items()):
        here = layer_of(module, table)
        assert here is not None
        for target in sorted(targets):
            there = layer_of(target, table)
            if there is not None and there > here:
                upward.append(f"{module} ({here}) -> {target} ({there})")
    assert not upward, "imports that point up a layer:\n" + "\n".join(upward)


def test_the_drivers_do_not_import_each_other() -> None:
    graph = import_graph()
    assert "nurimc.client.sync" not in graph["nurimc.client.aio"]
    assert "nurimc.client.aio" not in graph["nurimc.client.sync"]
