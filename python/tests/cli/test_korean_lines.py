"""The lines that came with product lines, reconnect, the restore journal and MCAP repair, in
Korean (issue 26 after the merge): what the library says is shown through the CLI's templates,
so a template that no longer matches its line (a library message reworded) fails here."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from nurimc.cli.i18n import tr
from nurimc.procedures.journal import incomplete_message
from nurimc.procedures.products import DESCRIPTIONS

from .inprocess import SIM, nurimc

HANGUL = re.compile("[\uac00-\ud7a3]")
KOREAN = {"LANGUAGE": "", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "ko_KR.UTF-8"}


@pytest.fixture(autouse=True)
def korean(monkeypatch: pytest.MonkeyPatch) -> None:
    for key, value in KOREAN.items():
        monkeypatch.setenv(key, value)


# Lines as the library writes them (nurimc.transport.outage, transport/reconnect.py, discovery, settings, motor)
LINES = {
    "port /dev/ttyUSB0 lost ([Errno 5] Input/output error); reopening it in the background": "다시 여는 중",
    "port /dev/ttyUSB0 is back after 3.1 s; sent first: stop 001": "3.1 s 만에 돌아왔습니다",
    "port /dev/ttyUSB0 is back after 3.1 s": "3.1 s 만에 돌아왔습니다",
    "could not stop ID 1: the port is lost; control off is sent first when it returns": "제어 Off",
    "could not stop ID 1, 2: port x is closed. The motors may still be turning: stop them by other means "
    "(cut their power)": "전원 차단",
    "port /dev/ttyUSB0 is lost ([Errno 5] Input/output error) at exit: motors could not be stopped on the way "
    "out; any motor still turning must be stopped by other means (cut its power)": "전원 차단",
    "the adapter at /dev/ttyUSB0 cannot be set to 110 bps ([Errno 22] Invalid argument); 110 bps skipped": "건너뜁니다",
    f"{incomplete_message('/tmp/robot.json')}; completing it now": "마저 복원합니다",
    "ID 1: 3 reads of position_gains all differ (kp=1, kp=2, kp=3): noise on the bus gets past the checksum, "
    "so nothing was written; check termination, grounding and the cable, then try again": "아무것도 쓰지 않았습니다",
    "ID 1: still turning at 12.5 RPM after speed 0 over 0.5 s (this firmware ignores speed 0 and an SM cannot "
    "hold a position); release() lets it coast": "12.5 RPM",
}


@pytest.mark.parametrize("line", list(LINES))
def test_library_line_in_korean(line: str) -> None:
    shown = tr(line)
    assert LINES[line] in shown and HANGUL.search(shown), shown


def test_product_line_notes_in_korean() -> None:
    for note in DESCRIPTIONS.values():
        assert tr(note) != note or not re.search("[a-z]{3,}", note), note


def test_a_line_number_is_digits() -> None:
    """`{where} line {line}` takes a file's line number, not 'Expecting value: line 1 column 1'."""
    shown = tr("robot.json line 3: not JSON (Expecting value: line 1 column 1 (char 0)); not a traffic log line")
    assert shown.startswith("robot.json 3번째 줄: ") and "(Expecting value: line 1 column 1 (char 0))" in shown


def test_status_and_refusals_of_a_line(tmp_path: Path) -> None:
    status = nurimc("--port", "sim://?ids=1&product=sm", "--id", "1", "status")
    assert status.code == 0 and "ID 1, 9600 bps: SM (sm)" in status.out and "부호 있음" in status.out
    moved = nurimc("--port", "sim://?ids=1&product=sm", "--id", "1", "move", "10")
    assert moved.code == 2 and "속도 전용 모터" in moved.err
    line = nurimc("decode", "--line", "rsx", "FF", "FE")
    assert line.code == 2 and "알 수 없는 제품군 'rsx'" in line.err
    scan = nurimc("--port", SIM, "scan", "--rates", "9600")
    assert "제품군" in scan.out and "MC 또는 BLMC-H" in scan.out
