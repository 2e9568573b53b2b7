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
FILES = Path(__file__).with_name("hostile_files")  # {files}: backup files that are not ours
SERVERS = ("sim", "dashboard")  # on success these serve until stopped: run apart, with a time limit
NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"


def _lines() -> list[tuple[int, str, str]]:
    """(exit code, arguments, text the output must hold) for each line of the list."""
    cases = []
    for line in LIST.read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            code, _, rest = line.strip().partition(" ")
            args, _, shows = rest.partition(" => ")
            cases.append((int(code), args.strip(), shows.strip()))
    return cases


def _cases() -> list[tuple[int, str]]:
    return [(code, args) for code, args, _ in _lines()]


def _argv(args: str, tmp: Path) -> list[str]:
    for key, value in (("{sim}", SIM), ("{tmp}", str(tmp)), ("{files}", str(FILES))):
        args = args.replace(key, shlex.quote(value))
    return shlex.split(args)


def test_the_list_covers_the_issue() -> None:
    listed = {args for _, args in _cases()}
    for must in (
        "--port {sim} --id 1 move -90",
        "--port {sim} --id 1 run -60",
        "--port {sim} --id 1 move 90 --rpm -5",
        "--port {sim} --id 1 watch --interval -1",
        "--port {sim} sniff --duration inf",
        "--port {sim} sniff --duration nan",
        "--port {sim} --id 1 set position-kp 1.5",
        "--port {sim} restore {files}/kp-true.json",
        "--port {sim} restore {files}/top-list.json",
        "--port {sim} restore {files}/top-text.json",
        "--port {sim} restore {files}/motors-only.json",
        "--port {sim} restore {files}/settings-text.json",
        "--port {sim} restore {files}/deep-list.json",
        "--port {sim} --id 1 backup /nonexistent/x.json",
        "--port 'sim://?state=/proc/x' --id 1 ping",
        "-v --port {sim} scan --rates 9600 --ids 0-1",
        "--port {sim} --id 1 status",
        "encode set_id new_id=1e400",
    ):
        assert must in listed, must
    assert len({(a, s) for _, a, s in _lines()}) == len(_lines()) > 200  # each line once
    files = {p.name for p in FILES.iterdir()}
    used = {a.split("{files}/")[1].split()[0] for a in listed if "{files}/" in a}
    assert files == used, f"files no line uses: {files - used}; lines naming missing files: {used - files}"


@pytest.mark.parametrize(("expected", "args", "shows"), [c for c in _lines() if not c[1].startswith(SERVERS)])
def test_hostile_call(expected: int, args: str, shows: str, tmp_path: Path) -> None:
    argv = _argv(args, tmp_path)
    result = nurimc(*argv)
    assert_clean(result, *argv)
    assert result.code == expected, f"nurimc {args}: {result.code}, expected {expected}: {result.err!r}"
    assert shows in result.out + result.err, f"nurimc {args}: {shows!r} not in {result.out + result.err!r}"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a temporary file outlived the call"


@pytest.mark.parametrize(("expected", "args"), [c for c in _cases() if c[1].startswith(SERVERS)])
def test_hostile_server_call(expected: int, args: str) -> None:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    try:
        done = subprocess.run(
            [NURIMC, *_argv(args, Path("."))],
            capture_output=True,
            text=True,
            timeout=60,
            env=env,
            stdin=subprocess.DEVNULL,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"nurimc {args}: still running after 60 s (it should have refused the value)")
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode != 0 and len(done.stderr.strip().splitlines()) == 1, done.stderr  # one line
    assert done.returncode == expected, f"nurimc {args}: {done.returncode}, expected {expected}: {done.stderr!r}"
