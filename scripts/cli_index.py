#!/usr/bin/env python3
"""Write python/src/nurimc/cli/command_index.py: each command module's commands and help, so that
`nurimc --help` lists them without importing the modules (docs/performance.md, Start-up).

    .venv/bin/python scripts/cli_index.py           write it
    .venv/bin/python scripts/cli_index.py --check   exit 1 if it is stale

Run it after adding or changing a command (tests/cli/test_startup.py fails until then).
"""

from __future__ import annotations

import sys
from pathlib import Path

TARGET = Path(__file__).resolve().parents[1] / "python/src/nurimc/cli/command_index.py"


def render() -> str:
    from nurimc.cli.app import command_index

    lines = [
        '"""Every command of `nurimc`, by the module that registers it: (name, help, short help, hidden).',
        "",
        "Written by scripts/cli_index.py (do not edit): `nurimc --help` lists the commands from here without",
        'importing their modules (docs/performance.md, Start-up)."""',
        "",
        "COMMAND_INDEX: dict[str, tuple[tuple[str, str | None, str | None, bool], ...]] = {",
    ]
    for module, entries in command_index().items():
        lines.append(f"    {module!r}: (")
        lines += [f"        {entry!r}," for entry in entries]
        lines.append("    ),")
    lines.append("}")
    return "\n".join(lines) + "\n"


def main() -> int:
    text = render()
    if "--check" in sys.argv[1:]:
        if not TARGET.exists() or TARGET.read_text() != text:
            print(f"{TARGET} is stale: run .venv/bin/python scripts/cli_index.py", file=sys.stderr)
            return 1
        return 0
    TARGET.write_text(text)
    print(f"wrote {TARGET}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
