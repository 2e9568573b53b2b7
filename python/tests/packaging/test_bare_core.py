"""The sans-I/O core stands alone: in a venv with no third-party package at all (not even pip),
`nurimc.protocol` and the conformance program import and answer every shared vector."""

from __future__ import annotations

import json
import os
import subprocess
import venv
from pathlib import Path

import pytest

from tests.conftest import ROOT, load_vectors

SRC = ROOT / "python" / "src"

# Run inside the bare venv: import the core, then list every top-level module loaded that is
# neither the standard library nor nurimc itself.
PROBE = """
import sys
sys.path.insert(0, {src!r})
import nurimc, nurimc.protocol, nurimc.conformance
from nurimc.protocol import decode
assert decode(bytes.fromhex("fffe00025da0")).name == "request_ping"
# sitecustomize/usercustomize are the interpreter installation's own start-up hooks (Debian ships one)
ours = {{"nurimc", "__main__", "sitecustomize", "usercustomize"}}
outside = sorted({{m.split(".")[0] for m in sys.modules}} - set(sys.stdlib_module_names) - ours)
print(" ".join(outside))
"""


@pytest.fixture(scope="module")
def bare_python(tmp_path_factory: pytest.TempPathFactory) -> Path:
    target = tmp_path_factory.mktemp("bare") / "venv"
    venv.EnvBuilder(with_pip=False, system_site_packages=False, symlinks=os.name != "nt").create(target)
    return target / ("Scripts/python.exe" if os.name == "nt" else "bin/python")


def bare_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}


def test_the_venv_is_bare(bare_python: Path) -> None:
    for module in ("serial", "typer", "rich", "nurimc"):
        proc = subprocess.run([bare_python, "-c", f"import {module}"], capture_output=True, text=True, env=bare_env())
        assert proc.returncode != 0 and "ModuleNotFoundError" in proc.stderr, module


def test_core_imports_nothing_outside_the_standard_library(bare_python: Path) -> None:
    proc = subprocess.run(
        [bare_python, "-c", PROBE.format(src=str(SRC))], capture_output=True, text=True, env=bare_env(), timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == []


def test_the_client_needs_pyserial_only_when_used(bare_python: Path) -> None:
    # the package top level is lazy: naming the bus client is what loads pyserial
    probe = f"import sys; sys.path.insert(0, {str(SRC)!r}); import nurimc; nurimc.Bus"
    proc = subprocess.run([bare_python, "-c", probe], capture_output=True, text=True, env=bare_env(), timeout=60)
    assert proc.returncode != 0 and "No module named 'serial'" in proc.stderr


def test_conformance_program_answers_every_vector(bare_python: Path) -> None:
    # the JSON vectors (edges.jsonl holds raw lines: conformance/check.py feeds those)
    vectors = [v for v in load_vectors() if "input" in v]
    stdin = "".join(json.dumps(v["input"]) + "\n" for v in vectors)
    proc = subprocess.run(
        [bare_python, "-m", "nurimc.conformance"],
        input=stdin,
        capture_output=True,
        text=True,
        env={**bare_env(), "PYTHONPATH": str(SRC)},
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    answers = [json.loads(line) for line in proc.stdout.splitlines()]
    wrong = [v["name"] for v, got in zip(vectors, answers, strict=True) if got != v["expect"]]
    assert len(answers) == len(vectors) > 1000 and wrong == []
