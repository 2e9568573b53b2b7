"""Start-up (issue 33, docs/performance.md): a one-shot command imports only what it uses.

Run in a fresh interpreter each (what `nurimc ...` does), then sys.modules is looked at: the
simulator, asyncio, the web console (Starlette) and the ROS 2 code must not be there."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from nurimc.cli.app import command_index
from nurimc.cli.command_index import COMMAND_INDEX

#: what no one-shot command needs (prefixes of module names)
HEAVY = ("nurimc.sim", "asyncio", "starlette", "uvicorn", "nurimc.ros2", "nurimc.dashboard", "cyclonedds", "mcap")

PROBE = """
import io, json, sys
sys.stdout = io.StringIO()
from nurimc.cli.app import main
try:
    main(json.loads(sys.argv[1]))
except SystemExit as end:
    code = end.code
sys.stdout = sys.__stdout__
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def modules_after(*args: str) -> tuple[int, list[str]]:
    done = subprocess.run(
        [sys.executable, "-c", PROBE, json.dumps(list(args))], capture_output=True, text=True, timeout=120, check=True
    )
    found = json.loads(done.stdout.strip().splitlines()[-1])
    return found["code"], found["modules"]


@pytest.mark.parametrize(
    "args", [["--help"], ["--version"], ["version"], ["status", "--help"], ["move", "--help"], ["decode", "FF FE"]]
)
def test_a_one_shot_command_imports_no_simulator_asyncio_console_or_ros2(args: list[str]) -> None:
    _, modules = modules_after(*args)
    heavy = [m for m in modules if m.startswith(HEAVY)]
    assert heavy == [], f"nurimc {' '.join(args)} imported {heavy}"


def test_help_and_version_import_no_command_module_and_no_serial_port_code() -> None:
    for args in (["--help"], ["--version"]):
        code, modules = modules_after(*args)
        assert code == 0
        loaded = [m for m in modules if m.startswith(("nurimc.cli.", "nurimc.drivers", "nurimc.transport", "serial"))]
        assert set(loaded) <= {
            "nurimc.cli.app",
            "nurimc.cli.common",
            "nurimc.cli.i18n",
            "nurimc.cli.messages",
            "nurimc.cli.command_index",
        }, loaded


def test_the_command_index_matches_the_commands_the_modules_register() -> None:
    assert command_index() == COMMAND_INDEX, "stale: run .venv/bin/python scripts/cli_index.py"
