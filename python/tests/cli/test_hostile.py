"""The hostile argument list (hostile_args.txt): each call gets its promised exit code, one clean
error line at most, no traceback, no hang."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from .inprocess import SIM, assert_clean, nurimc

LIST = Path(__file__).with_name("hostile_args.txt")
SERVERS = ("sim", "dashboard")  # on success these serve until stopped: run apart, with a time limit
NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def _cases() -> list[tuple[int, str]]:
    cases = []
    for line in LIST.read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            code, _, args = line.strip().partition(" ")
            cases.append((int(code), args))
    return cases


def test_the_list_covers_the_issue() -> None:
    listed = {args for _, args in _cases()}
    for must in ("--port {sim} --id 1 move -90", "--port {sim} sniff --duration inf", "encode set_id new_id=1e400"):
        assert must in listed
    assert len(listed) > 120


@pytest.mark.parametrize(("expected", "args"), [c for c in _cases() if not c[1].startswith(SERVERS)])
def test_hostile_call(expected: int, args: str, tmp_path: Path) -> None:
    argv = shlex.split(args.replace("{sim}", shlex.quote(SIM)).replace("{tmp}", shlex.quote(str(tmp_path))))
    result = nurimc(*argv)
    assert_clean(result, *argv)
    assert result.code == expected, f"nurimc {args}: {result.code}, expected {expected}: {result.err!r}"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a temporary file outlived the call"


@pytest.mark.parametrize(("expected", "args"), [c for c in _cases() if c[1].startswith(SERVERS)])
def test_hostile_server_call(expected: int, args: str) -> None:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    try:
        done = subprocess.run(
            [NURIMC, *shlex.split(args)], capture_output=True, text=True, timeout=10, env=env, stdin=subprocess.DEVNULL
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"nurimc {args}: still running after 10 s (it should have refused the value)")
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode != 0 and len(done.stderr.strip().splitlines()) == 1, done.stderr  # one line
    assert done.returncode == expected, f"nurimc {args}: {done.returncode}, expected {expected}: {done.stderr!r}"
