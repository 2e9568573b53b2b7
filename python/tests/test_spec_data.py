"""Spec data used, not retyped (issue 23): a known limit (spec/host.json `limits`) or the table
of baud rates typed by hand outside the generated code fails this test; so does a simulator
setting or a product name that is not the generated spec's."""

from __future__ import annotations

import ast
from pathlib import Path

from nurimc.protocol import BAUD_RATES, PRODUCTS
from nurimc.protocol._settings import SETTINGS as SPEC_SETTINGS
from nurimc.protocol.host import LIMITS
from nurimc.sim.settings import _WRITERS

SRC = Path(__file__).resolve().parents[1] / "src" / "nurimc"
GENERATED = {"protocol/_tables.py", "protocol/_host.py", "protocol/_settings.py", "protocol/messages.py"}
#: A limit that is also a step or a unit (0.1 RPM, 0.1 s) is everywhere as a scale: not checked.
LIMIT_VALUES = {value for value in LIMITS.values() if value != 0.1}
#: Places known to hold such a value, each with why (delete an entry when its file is fixed).
KNOWN: dict[tuple[str, object], str] = {}  # (file, value) -> why it may stay; none may


def _number(node: ast.AST) -> float | None:
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        inner = _number(node.operand)
        return None if inner is None else -inner
    if isinstance(node, ast.Constant) and isinstance(node.value, int | float) and not isinstance(node.value, bool):
        return float(node.value)
    return None


def findings(rel: str, source: str) -> list[tuple[str, object, int]]:
    """Limits and rate tables typed in one module's source."""
    found: list[tuple[str, object, int]] = []
    for node in ast.walk(ast.parse(source)):
        value = _number(node)
        if value is not None and abs(value) in LIMIT_VALUES:
            hit = (rel, abs(value), getattr(node, "lineno", 0))
            if hit not in found:  # once: -655.36 is a minus and its number
                found.append(hit)
        if isinstance(node, ast.List | ast.Tuple | ast.Set | ast.Dict):
            items = node.keys if isinstance(node, ast.Dict) else node.elts
            rates = {_number(n) for n in items if n is not None} & {float(r) for r in BAUD_RATES}
            if len(rates) > len(BAUD_RATES) // 2:  # the table of rates, retyped
                found.append((rel, "rates", node.lineno))
    return found


def typed_by_hand() -> list[tuple[str, object, int]]:
    found: list[tuple[str, object, int]] = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel not in GENERATED:
            found += findings(rel, path.read_text(encoding="utf-8"))
    return found


def test_no_limit_or_rate_table_is_typed_by_hand() -> None:
    unexpected = [(f, v, line) for f, v, line in typed_by_hand() if (f, v) not in KNOWN]
    assert unexpected == [], (
        f"typed by hand: {unexpected}; use nurimc.protocol.host.LIMITS / nurimc.protocol.BAUD_RATES (generated)"
    )


def test_the_check_sees_a_retyped_limit_and_table() -> None:
    """The scan itself works: a module that retypes a limit and the rate table is caught."""
    rates = ", ".join(map(str, BAUD_RATES))
    source = f"MAX_RPM = {LIMITS['speed_rpm_max']}\nWRAP = -{LIMITS['position_wrap_deg']}\nRATES = ({rates})\n"
    assert findings("x.py", source) == [
        ("x.py", LIMITS["speed_rpm_max"], 1),
        ("x.py", LIMITS["position_wrap_deg"], 2),
        ("x.py", "rates", 3),
    ]


def test_the_simulators_settings_and_the_product_names_come_from_the_spec() -> None:
    writable = {s["name"].replace("-", "_"): (s["command"], s["field"]) for s in SPEC_SETTINGS if s["command"]}
    assert {k: (cls.SPEC.name, f) for k, (cls, f) in _WRITERS.items() if k not in ("id", "baud_index")} == writable
    for path in sorted(SRC.rglob("*.py")):  # no list of the product names typed by hand
        if path.relative_to(SRC).as_posix() in GENERATED:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.List | ast.Tuple | ast.Set):
                names = {n.value for n in node.elts if isinstance(n, ast.Constant) and isinstance(n.value, str)}
                assert not names >= set(PRODUCTS), f"{path}:{node.lineno}: product names typed by hand"
