"""Optional parts of the package and the pip extra that installs each (python/pyproject.toml)."""

from __future__ import annotations

import importlib.util

# extra -> the top-level modules it brings
EXTRAS: dict[str, tuple[str, ...]] = {
    "dashboard": ("starlette", "uvicorn", "websockets"),
}


def missing_extra(extra: str) -> str | None:
    """A one-line hint naming the extra to install, or None when every module it brings imports."""
    missing = [name for name in EXTRAS[extra] if importlib.util.find_spec(name) is None]
    if not missing:
        return None
    return f"this needs the {extra} extra ({', '.join(missing)} not installed): pip install 'nurimc[{extra}]'"
