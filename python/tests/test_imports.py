"""No import cycle in python/src/nurimc: every import counts, wherever it is written.

The graph is read from the source (ast), not from a running interpreter, so imports inside
functions (deferred), under `if TYPE_CHECKING:` and at the bottom of a module all count.
An edge goes from a module to each nurimc module it names; importing a package's submodule
implicitly runs the package's __init__, which is not counted (else every package would cycle
with its own __init__).
"""

from __future__ import annotations

import ast
from pathlib import Path

import nurimc

ROOT = Path(nurimc.__file__).parent


def module_names() -> dict[str, tuple[Path, bool]]:
    """Dotted name -> (file, is a package __init__)."""
    out: dict[str, tuple[Path, bool]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
        package = parts[-1] == "__init__"
        if package:
            parts = parts[:-1]
        out[".".join(parts)] = (path, package)
    return out


def lazy_import(node: ast.AST) -> str | None:
    """The module named by importlib.import_module("...", ...) (the lazy top level), if node is one."""
    if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
        return None
    if node.func.attr != "import_module" or not node.args:
        return None
    first = node.args[0]
    return first.value if isinstance(first, ast.Constant) and isinstance(first.value, str) else None


def imports_of(name: str, path: Path, package: bool, modules: dict[str, tuple[Path, bool]]) -> set[str]:
    """The nurimc modules `name` imports anywhere in its source."""
    here = name if package else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".")
                base = base[: len(base) - node.level + 1]
                source = ".".join([*base, node.module] if node.module else base)
            else:
                source = node.module or ""
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                found.add(submodule if submodule in modules else source)
        elif (target := lazy_import(node)) is not None:
            if target.startswith("."):
                level = len(target) - len(target.lstrip("."))
                base = here.split(".")
                base = base[: len(base) - level + 1]
                rest = target.lstrip(".")
                target = ".".join([*base, rest] if rest else base)
            found.add(target)
    return {m for m in found if m in modules and m != name}


def import_graph() -> dict[str, set[str]]:
    modules = module_names()
    return {name: imports_of(name, path, package, modules) for name, (path, package) in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle (as a path a -> ... -> a), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            if nxt not in state and (cycle := visit(nxt)) is not None:
                return cycle
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (cycle := visit(start)) is not None:
            return cycle
    return None


def test_the_reader_sees_every_kind_of_import() -> None:
    graph = import_graph()
    assert len(graph) > 50
    assert "nurimc.procedures.motor" in graph["nurimc.drivers.sync"]  # from ..motor import Motor
    assert "nurimc.core.buscore" in graph["nurimc.procedures.motor"]  # from .client.core import BusCore
    assert "nurimc.drivers.sync" in graph["nurimc"]  # under if TYPE_CHECKING: (and the lazy table)
    assert "nurimc.drivers.aio" in graph["nurimc"]  # importlib.import_module(".client.aio", __name__)
    assert "nurimc.protocol.units" in graph["nurimc.protocol.schema"]  # inside a function
    assert "nurimc.procedures.discovery" in graph["nurimc.cli.ros2_cmd"]  # inside a function
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycle() -> None:
    cycle = find_cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])
