"""Every shared vector, through the in-process conformance function and through conformance/run."""

from __future__ import annotations

import importlib.util
import io
import json
import subprocess
import sys

import pytest

from nurimc.conformance import answer, serve
from nurimc.protocol import SPECS, decode, make

from ..conftest import ROOT, load_vectors

VECTORS = load_vectors()
_spec = importlib.util.spec_from_file_location("conformance_check", ROOT / "conformance" / "check.py")
assert _spec is not None and _spec.loader is not None
check = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check)


@pytest.mark.parametrize("vector", VECTORS, ids=[v["name"] for v in VECTORS])
def test_vector(vector: dict) -> None:
    if "input" in vector:
        assert answer(vector["input"]) == vector["expect"]
    out = io.BytesIO()
    serve(io.BytesIO(check.line_of(vector) + b"\n"), out)
    lines = out.getvalue().split(b"\n")
    assert lines[-1] == b"" and len(lines) == 2  # exactly one answer line
    assert check.comparable(json.loads(lines[0])) == check.expand(vector["expect"])


def test_document_examples_round_trip_byte_for_byte() -> None:
    spec = json.loads((ROOT / "spec" / "protocol.json").read_text())
    consistent = [ex for ex in spec["examples"] if "printed" not in ex]
    assert len(consistent) == 25
    for ex in spec["examples"]:
        raw = bytes.fromhex(ex["hex"])
        message = decode(raw)
        assert message.to_dict() == {"id": ex["id"], "message": ex["message"], **ex["fields"]}
        assert message.encode() == raw
        assert make(ex["message"], ex["id"], **ex["fields"]).encode() == raw


def test_every_message_has_vectors() -> None:
    names = {v["input"].get("message") for v in VECTORS if "input" in v} | {v["expect"].get("message") for v in VECTORS}
    assert set(SPECS) <= names
    assert len(SPECS) == 42  # 16 commands + 13 requests (section 17) + 13 answers = 30 sections


def test_conformance_program_speaks_json_lines() -> None:
    lines = [
        '{"op":"decode","hex":"fffe0007760100465003e8"}',
        "not json",
        '{"op":"encode","id":0,"message":"position_speed","direction":0,"position":18000,"speed":0}',
    ]
    proc = subprocess.run(
        [str(ROOT / "conformance" / "run"), "python"],
        input="\n".join(lines) + "\n",
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    out = [json.loads(line) for line in proc.stdout.splitlines()]
    assert out[0] == {"id": 0, "message": "position_speed", "direction": 0, "position": 18000, "speed": 1000}
    assert out[1]["error"] == "bad_request"
    assert out[2] == {"error": "range", "field": "speed"}


def test_vectors_and_generated_code_are_fresh() -> None:
    for tool in ("make_vectors.py", "generate.py"):
        proc = subprocess.run([sys.executable, str(ROOT / "tools" / tool), "--check"], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
