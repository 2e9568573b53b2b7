#!/usr/bin/env python3
"""Generate every language's protocol tables from spec/protocol.json.

Each language has a module tools/gen_<lang>.py with `generate(spec, check) -> stale paths`.
`--check` writes nothing and fails if any generated file differs from what the spec gives
(CI runs it, so generated code can never drift from the spec).

Usage: python3 tools/generate.py [--check]
"""

from __future__ import annotations

import importlib
import sys

import speclib

GENERATORS = ("gen_python", "gen_c", "gen_ts", "gen_host", "gen_settings")


def main() -> int:
    check = "--check" in sys.argv[1:]
    stale = []
    for name in GENERATORS:
        module = importlib.import_module(name)  # a missing or broken generator fails loudly
        stale += module.generate(speclib.load(), check)
    for path in stale:
        verb = "stale" if check else "wrote"
        print(f"{verb}: {path.relative_to(speclib.ROOT)}", file=sys.stderr if check else sys.stdout)
    if check and stale:
        print("generated code is stale: run `make generate` and commit the result", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
