"""Issue 24 from outside: what a newcomer met in the first hour, each checked through the
command line (stop/run 0/move --wait: test_stop.py; the docs' figures: tests/docs)."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nurimc.cli import demo

from .inprocess import SIM, assert_clean, nurimc
from .test_signals import NURIMC


def start(*args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "NO_COLOR": "1", "COLUMNS": "200"}
    env.pop("NURIMC_PORT", None)
    return subprocess.Popen(
        [NURIMC, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, stdin=subprocess.DEVNULL
    )


def test_nurimc_alone_prints_the_help() -> None:
    result = nurimc()
    assert result.code == 0 and result.err == ""
    assert result.out.startswith("Usage: nurimc") and "\n  scan " in result.out and "Commands" in result.out


def test_encode_follows_set_and_the_broadcast_rule() -> None:
    assert nurimc("encode", "set_ratio", "ratio=12.5").out.strip() == "FF FE 00 04 73 0B 00 7D"  # 12.5:1, as set
    assert nurimc("encode", "set_ratio", "ratio=125").out.strip() == "FF FE 00 04 73 0B 00 7D"  # the wire value
    broadcast = nurimc("encode", "request_ping", "--to", "255")
    assert broadcast.code == 0 and broadcast.out.strip() == "FF FE FF 02 5E A0"
    assert "every controller answers" in broadcast.err
    assert nurimc("encode", "set_id", "new_id=1.5").code == 2  # a count takes no fraction


def test_decode_spells_units_as_everything_else() -> None:
    out = nurimc("decode", "FF", "FE", "00", "07", "76", "01", "00", "46", "50", "03", "E8").out
    assert "180°" in out and "100 RPM" in out and " deg" not in out and " rpm" not in out


def test_scan_and_backup_name_the_product_alike(tmp_path: Path) -> None:
    scanned = json.loads(nurimc("--port", SIM, "--json", "scan", "--rates", "9600").out)
    backup = tmp_path / "bus.json"
    assert nurimc("--port", SIM, "--id", "0,1", "backup", str(backup)).code == 0
    written = {m["id"]: m["product"] for m in json.loads(backup.read_text())["motors"]}
    assert {f["id"]: f["product_guess"] for f in scanned} == written == {0: "mc", 1: "mc"}


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_factory_reset_answered_no_is_a_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stdin", _Terminal("n\n"))
    result = nurimc("--port", SIM, "--id", "1", "factory-reset")
    assert result.code == 0 and "error" not in result.err and "not reset: answered no" in result.err


def test_factory_reset_from_a_pipe_says_how_to_confirm(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stdin", io.StringIO("y\n"))
    result = nurimc("--port", SIM, "--id", "1", "factory-reset")
    assert_clean(result)
    assert result.code == 2 and "factory-reset --yes" in result.errors[0]


def test_long_titles_are_lines_of_their_own(tmp_path: Path) -> None:
    folder = tmp_path / ("a-long-folder-name-" * 4)
    folder.mkdir()
    backup = folder / "robot.json"
    assert nurimc("--port", SIM, "--id", "0,1", "backup", str(backup)).code == 0
    restored = nurimc("--port", SIM, "restore", str(backup))
    assert f"restored from {backup}\n" in restored.out


def test_make_demo_hint_names_the_program_as_run(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    program = tmp_path / ".venv" / "bin" / "nurimc"
    program.parent.mkdir(parents=True)
    program.write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "argv", [str(program)])
    monkeypatch.setenv("PATH", "/usr/bin:/bin")
    assert demo.invoked_as() == ".venv/bin/nurimc"


def test_simulator_reads_like_a_real_encoder(tmp_path: Path) -> None:
    link = tmp_path / "bus"
    sim = start("sim", "--link", str(link), "--ids", "1")
    try:
        deadline = time.monotonic() + 90
        while not link.exists():
            assert sim.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        got = subprocess.run(
            [NURIMC, "--port", str(link), "--id", "1", "--json", "get", "resolution"], capture_output=True, text=True
        )
        assert json.loads(got.stdout)["value"] == 1024
    finally:
        sim.terminate()
        sim.communicate(timeout=60)
    assert "--resolution" in subprocess.run([NURIMC, "sim", "--help"], capture_output=True, text=True).stdout


def _interrupt_after(proc: subprocess.Popen[str], *seen: str) -> tuple[int, str, str]:
    """Ctrl+C once stderr has shown lines holding each of `seen`, in order (-v's frames)."""
    assert proc.stderr is not None
    deadline = time.monotonic() + 90
    for text in seen:
        while text not in proc.stderr.readline():
            assert proc.poll() is None and time.monotonic() < deadline, f"never saw {text!r}"
    proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("still running 60 s after Ctrl+C")
    return proc.returncode, out, err


@pytest.mark.parametrize("json_output", [False, True])
def test_ctrl_c_during_scan_says_so_and_shows_what_was_found(json_output: bool) -> None:
    # wire timing: 18 rates take seconds; Ctrl+C once ID 1 has answered at 9600 (the first rate)
    # and the next rate's broadcast ping has gone out (the progress then holds it)
    proc = start("--port", "sim://?ids=1&wire_timing=1", "-v", *(["--json"] if json_output else []), "scan")
    code, out, err = _interrupt_after(proc, "<- ping id=1", "-> request_ping id=255")
    assert code == 130 and "Traceback" not in err
    assert "interrupted: the scan stopped early" in err
    if json_output:
        assert [f["id"] for f in json.loads(out)] == [1]
    else:
        assert "(interrupted)" in out and "│ 1 " in out


def test_ctrl_c_stops_watch_at_once_even_when_readings_fail() -> None:
    """The signal only sets a flag that the loop reads between readings (common.stop_flag)."""
    proc = start("--port", "sim://?ids=1", "-v", "--id", "1,9", "--json", "watch", "--interval", "0.01")
    code, out, err = _interrupt_after(proc, "<- position_feedback id=1", "-> request_position id=9")
    assert code == 0 and "Traceback" not in err and json.loads(out)[0]["id"] == 1
