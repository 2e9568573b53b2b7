"""The CLI in Korean (issue 26): LANG=ko_KR.UTF-8 (or LC_ALL, LC_MESSAGES, LANGUAGE) gives Korean
help, tables and messages; the hostile list keeps its exit codes and its one clean line in
Korean; --json is the same in both languages; the catalogs are complete and compiled."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from nurimc.cli.i18n import FIELD, _pattern
from nurimc.cli.messages import PATTERNS

from .inprocess import SIM, assert_clean, nurimc
from .test_hostile import SERVERS, _argv, _lines

ROOT = Path(__file__).resolve().parents[3]
NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
HANGUL = re.compile("[\uac00-\ud7a3]")
KOREAN = {"LANGUAGE": "", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "ko_KR.UTF-8"}


def _catalogs() -> Any:
    spec = importlib.util.spec_from_file_location("catalogs", ROOT / "scripts/catalogs.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def korean(monkeypatch: pytest.MonkeyPatch) -> None:
    for key, value in KOREAN.items():
        monkeypatch.setenv(key, value)


def cli(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    full = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", **env}
    full.pop("NURIMC_PORT", None)
    return subprocess.run([NURIMC, *args], capture_output=True, text=True, timeout=60, env=full)


def test_catalogs_are_complete_and_compiled() -> None:
    """Every help text, template and message has Korean, and each .mo is its .po compiled."""
    assert _catalogs().check() == []


def test_every_template_compiles() -> None:
    for template in PATTERNS:
        _pattern(template)  # a field named twice in one template would fail here


def test_templates_keep_their_fields() -> None:
    """A translated template uses only the fields its English has (or formatting would fail)."""
    catalogs = _catalogs()
    catalog = catalogs.load("ko")
    for message in catalog:
        if message.id and message.string:
            assert set(FIELD.findall(message.string)) <= set(FIELD.findall(message.id)), message.id


@pytest.mark.parametrize(
    "env",
    [
        KOREAN,
        {"LANGUAGE": "", "LC_MESSAGES": "", "LANG": "C", "LC_ALL": "ko_KR.UTF-8"},
        {"LANGUAGE": "ko", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "C.UTF-8"},
    ],
    ids=["LANG", "LC_ALL", "LANGUAGE"],
)
def test_help_is_korean(env: dict[str, str]) -> None:
    proc = cli("--help", env=env)
    assert proc.returncode == 0 and proc.stdout.startswith("사용법: nurimc")
    assert "누리로봇" in proc.stdout and "옵션:" in proc.stdout and "명령:" in proc.stdout
    assert "이 도움말을 보이고 끝냅니다." in proc.stdout


@pytest.mark.parametrize(
    "env", [{"LANGUAGE": "", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "C.UTF-8"}, {**KOREAN, "LANGUAGE": "en:ko"}]
)
def test_english_otherwise(env: dict[str, str]) -> None:
    proc = cli("--help", env=env)
    assert proc.stdout.startswith("Usage: nurimc") and not HANGUL.search(proc.stdout)


def test_scan_and_status_in_korean(korean: None) -> None:
    scan = nurimc("--port", SIM, "scan", "--rates", "9600")
    assert scan.code == 0 and "제어기 2개를 찾았습니다" in scan.out and "통신속도" in scan.out
    status = nurimc("--port", SIM, "--id", "1", "status")
    assert status.code == 0 and "측정값" in status.out and "위치 부호" in status.out
    assert "position-kp" in status.out and "firmware" in status.out  # setting names stay as typed
    moved = nurimc("--port", SIM, "--id", "1", "move", "10", "--rpm", "60")
    assert moved.out.strip() == "ID 1: 10.0°로 60.0 RPM으로 이동 중"


def test_json_is_the_same_in_both_languages(monkeypatch: pytest.MonkeyPatch) -> None:
    english = nurimc("--port", SIM, "--json", "scan", "--rates", "9600")
    for key, value in KOREAN.items():
        monkeypatch.setenv(key, value)
    korean = nurimc("--port", SIM, "--json", "scan", "--rates", "9600")
    assert json.loads(english.out) == json.loads(korean.out) and english.out == korean.out


@pytest.mark.parametrize(("expected", "args", "shows"), [c for c in _lines() if not c[1].startswith(SERVERS)])
def test_hostile_call_in_korean(expected: int, args: str, shows: str, tmp_path: Path, korean: None) -> None:
    """The hostile list in Korean: the same exit codes, one clean line, and that line in Korean."""
    argv = _argv(args, tmp_path)
    result = nurimc(*argv)
    assert_clean(result, *argv, prefixes=("오류: ", "참고: ", "경고: "))
    assert result.code == expected, f"nurimc {args}: {result.code}, expected {expected}: {result.err!r}"
    for line in result.err.splitlines():
        if line.startswith("오류: "):
            assert HANGUL.search(line[4:]), (
                f"nurimc {args}: not translated: {line!r}. Add its template to nurimc/cli/messages.py "
                "(PATTERNS), run scripts/catalogs.py --update, give its Korean in "
                "cli/locale/ko/LC_MESSAGES/nurimc.po, then run scripts/catalogs.py"
            )


@pytest.mark.parametrize(("expected", "args"), [(c, a) for c, a, _ in _lines() if a.startswith(SERVERS)])
def test_hostile_server_call_in_korean(expected: int, args: str) -> None:
    """The simulator's and the console's refusals (they run apart: on success they would serve)."""
    done = cli(*_argv(args, Path(".")), env=KOREAN)
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert done.returncode == expected, f"nurimc {args}: {done.returncode}, expected {expected}: {done.stderr!r}"
    assert HANGUL.search(done.stderr.split(":", 1)[1]), f"nurimc {args}: not translated: {done.stderr!r}"
