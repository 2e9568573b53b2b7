"""The Korean docs (issue 26) say the same commands as the English ones, and README.ko.md's
quick start works as written (against the simulator, in Korean)."""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
NURIMC = shutil.which("nurimc", path=str(Path(sys.executable).parent)) or "nurimc"
KOREAN = {"LANGUAGE": "", "LC_ALL": "", "LC_MESSAGES": "", "LANG": "ko_KR.UTF-8"}
FENCE = re.compile(r"```[^\n]*\n(.*?)```", re.DOTALL)
INLINE = re.compile(r"`((?:nurimc|make|\.venv/bin/nurimc)(?: [^`]*)?)`")


def block_lines(text: str) -> set[str]:
    """Every line of every fenced block, without its trailing comment (comments are translated)."""
    lines = set()
    for block in FENCE.findall(text):
        for line in block.splitlines():
            code = re.sub(r"\s+#\s.*$", "", line).rstrip()
            if code.strip() and not code.lstrip().startswith("#"):
                lines.add(code)
    return lines


def commands(text: str) -> set[str]:
    """Fenced lines and inline `nurimc …` / `make …` commands."""
    return block_lines(text) | set(INLINE.findall(FENCE.sub("", text)))


def read(path: str) -> str:
    return (ROOT / path).read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("english", "korean"),
    [("docs/cli.md", "docs/ko/cli.md"), ("docs/troubleshooting.md", "docs/ko/troubleshooting.md")],
)
def test_guides_say_the_same_commands(english: str, korean: str) -> None:
    assert commands(read(korean)) == commands(read(english))


def test_console_guide_has_the_same_command_blocks() -> None:
    """The console guide is translated short: its command blocks, not every inline mention."""
    assert block_lines(read("docs/ko/dashboard.md")) == block_lines(read("docs/dashboard.md"))


def test_readme_ko_has_the_quick_start_and_nothing_else() -> None:
    english, korean = read("README.md"), read("README.ko.md")
    start = english[: english.index("## What is here")]  # the opening, the quick start, the example
    assert block_lines(start) <= block_lines(korean) <= block_lines(english)
    assert "README.ko.md" in english.splitlines()[2]  # linked from the first lines


def test_readme_ko_quick_start_works(tmp_path: Path) -> None:
    """README.ko.md's commands, run as written (the pty link in a scratch folder), in Korean."""
    korean = read("README.ko.md")
    lines = [line for line in block_lines(korean) if line.startswith("nurimc ")]
    link = tmp_path / "nurimc0"
    env = {**os.environ, "NO_COLOR": "1", "COLUMNS": "200", **KOREAN}
    env.pop("NURIMC_PORT", None)
    sim_line = next(line for line in lines if line.startswith("nurimc sim "))
    sim_argv = shlex.split(sim_line.replace("/tmp/nurimc0", str(link)).rstrip("& "))
    background_pid: int | None = None
    if "--background" in sim_argv:  # returns once served, the simulator running on: its PID to stop it
        started = subprocess.run([NURIMC, *sim_argv[1:]], env=env, capture_output=True, text=True, timeout=180)
        found = re.search(r"kill (\d+)", started.stdout)
        assert started.returncode == 0 and found, (started.stdout, started.stderr)
        background_pid = int(found.group(1))
        sim_argv = [a for a in sim_argv if a != "--background"]
    sim = (
        None
        if background_pid
        else subprocess.Popen(
            [NURIMC, *sim_argv[1:]], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
    )
    try:
        deadline = time.monotonic() + 90
        while not link.exists():
            assert sim is not None and sim.poll() is None and time.monotonic() < deadline, sim and sim.communicate()
            time.sleep(0.05)
        ran = 0
        for line in sorted(lines):  # move before status is what the README shows; order is not needed
            if line == sim_line:
                continue
            argv = shlex.split(line.replace("/tmp/nurimc0", str(link)))
            proc = subprocess.run([NURIMC, *argv[1:]], env=env, capture_output=True, text=True, timeout=60)
            assert proc.returncode == 0 and not proc.stderr, (line, proc.stderr)
            assert re.search("[\uac00-\ud7a3]", proc.stdout), (line, proc.stdout)
            ran += 1
        assert ran == 3
        python = FENCE.findall(korean.split("```python", 1)[1].join(["```python", ""]))[0]
        script = python.replace("/tmp/nurimc0", str(link))
        proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0, proc.stderr
        assert "device_position=90" in proc.stdout or "device_position=89.9" in proc.stdout, proc.stdout
    finally:
        if sim is not None:
            sim.terminate()
            sim.communicate(timeout=60)
        if background_pid is not None:
            stop_background(background_pid)


def stop_background(pid: int) -> None:
    """SIGTERM the simulator --background left running, and wait until it is gone."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
