#!/usr/bin/env python3
"""Run every shared vector through one conformance executable (e.g. the sanitizer build).

Usage: run_vectors.py EXECUTABLE — conformance/check.py's rules, with an explicit program.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "conformance"))
import check  # (conformance/check.py: the one vector reader and comparer)

if __name__ == "__main__":
    sys.exit(check.check([sys.argv[1]], sys.argv[1]))
