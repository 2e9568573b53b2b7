"""One meaning per name (issue 23): no two classes share a name across python/src."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def classes() -> dict[str, list[str]]:
    found: dict[str, list[str]] = defaultdict(list)
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                found[node.name].append(path.relative_to(SRC).as_posix())
    return found


def test_no_two_classes_share_a_name() -> None:
    found = classes()
    assert len(found) > 100  # the walk sees the whole tree
    clashes = {name: places for name, places in found.items() if len(places) > 1}
    assert clashes == {}, f"classes that share a name: {clashes}; give each a name that says what it is"
