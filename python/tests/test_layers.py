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


#: the package itself: its row names its `__init__` only, never its submodules (no catch-all row)
TOP = "nurimc"


def layer_of(module: str, table: dict[str, int]) -> int | None:
    matches = [p for p in table if module == p or (p != TOP and module.startswith(p + "."))]
    return table[max(matches, key=len)] if matches else None


def test_the_table_is_read() -> None:
    table = layers()
    assert table["nurimc.protocol"] == 0 and table["nurimc.core"] == 2 and table["nurimc.drivers"] == 5
    assert layer_of("nurimc.core.buscore", table) == 2 and layer_of("nurimc.drivers.aio", table) == 5
    assert layer_of("nurimc.protocol.units", table) == 0 and layer_of("nurimc.sim.bus", table) == 7


def test_a_module_no_row_names_has_no_layer() -> None:
    """The top-level row is no catch-all: a new module must be placed in the table by hand."""
    table = layers()
    assert layer_of("nurimc", table) == table[TOP]
    assert layer_of("nurimc.brand_new_module", table) is None
    assert layer_of("nurimc.brand_new_package.part", table) is None
    assert layer_of("nurimc.procedures.brand_new", table) == table["nurimc.procedures"]


def test_the_folders_are_the_layers() -> None:
    """Below the applications, a layer is a folder (or, for the foundations, a named module)."""
    table = layers()
    for name, number in table.items():
        if 0 < number < 7 and name != TOP:
            assert name.count(".") == 1, f"{name}: a layer row names a top-level folder or module"


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
    assert "nurimc.drivers.sync" not in graph["nurimc.drivers.aio"]
    assert "nurimc.drivers.aio" not in graph["nurimc.drivers.sync"]
