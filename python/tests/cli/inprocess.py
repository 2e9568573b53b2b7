"""Run `nurimc` in this process (fast: no interpreter start-up) and check what a person sees."""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass

from nurimc.cli.app import main

#: A simulated bus with controllers at IDs 0 and 1 (fresh for each call).
SIM = "sim://?ids=0,1"

#: What may start a line on stderr: an error (at most one), a note (a value the wire rounds), a warning.
PREFIXES = ("error: ", "note: ", "warning: ")


@dataclass
class Result:
    code: int
    out: str
    err: str

    @property
    def errors(self) -> list[str]:
        return [line for line in self.err.splitlines() if line.startswith(("error: ", "오류: "))]


def nurimc(*args: str) -> Result:
    """`nurimc ARGS` in-process: the exit code, stdout and stderr."""
    out, err = io.StringIO(), io.StringIO()
    saved = {k: os.environ.pop(k, None) for k in ("NURIMC_PORT", "NURIMC_ID", "NURIMC_BAUD")}
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main(list(args))
                code = 0
            except SystemExit as done:
                code = done.code if isinstance(done.code, int) else 1
    finally:
        os.environ.update({k: v for k, v in saved.items() if v is not None})
    return Result(code, out.getvalue(), err.getvalue())


def assert_clean(result: Result, *args: str, prefixes: tuple[str, ...] = PREFIXES) -> None:
    """The promise for any input: exit 0, 1 or 2; no traceback; stderr made of one-line messages,
    at most one error, and exactly one when the exit code is not 0 (-v adds frame lines: -> and <-)."""
    where = f"nurimc {' '.join(args)!r} -> {result.code}: {result.err!r}"
    assert result.code in (0, 1, 2), where
    assert "Traceback" not in result.err and "Traceback" not in result.out, where
    lines = [line for line in result.err.splitlines() if line.strip() and not line.startswith(("-> ", "<- "))]
    assert all(line.startswith(prefixes) for line in lines), where
    assert len(result.errors) == (0 if result.code == 0 else 1), where
    assert "this is a bug" not in result.err, where  # an exception no check knew about
