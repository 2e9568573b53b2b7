"""A recording says when a joint's continuous position became uncertain (issue #37): the
bridge's diagnostics, with position_uncertain per joint, on /diagnostics."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

mcap = pytest.importorskip("mcap")

from mcap.reader import make_reader  # noqa: E402

from nurimc.cli.record_cmd import DIAGNOSTICS_TOPIC, note_uncertain  # noqa: E402
from nurimc.procedures.motor import MotorState  # noqa: E402
from nurimc.recording.mcap_file import McapRecorder  # noqa: E402
from nurimc.ros2 import msgs  # noqa: E402
from nurimc.ros2.bridge import Bridge  # noqa: E402


def reading(device_id: int, uncertain: bool) -> MotorState:
    return MotorState(device_id, 700.0, 44.64, 100.0, 0.4, "ccw", position_uncertain=uncertain)


def test_the_recording_says_when_turns_became_unknown(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    recorder = McapRecorder(path)
    bridge = Bridge([1, 2], ["a", "b"])
    seen: set[int] = set()
    bridge.readings({1: reading(1, False), 2: reading(2, False)})
    assert not note_uncertain(recorder, bridge, seen, 1, "sim://")  # nothing to say
    bridge.readings({1: reading(1, False), 2: reading(2, True)})
    assert note_uncertain(recorder, bridge, seen, 2, "sim://")
    bridge.readings({1: reading(1, False), 2: reading(2, True)})
    assert not note_uncertain(recorder, bridge, seen, 3, "sim://")  # said once, not every reading
    recorder.close()
    with path.open("rb") as stream:
        found: list[Any] = [
            msgs.TYPES[schema.name].deserialize(message.data)
            for schema, channel, message in make_reader(stream).iter_messages()
            if channel.topic == DIAGNOSTICS_TOPIC and schema is not None
        ]
    assert len(found) == 1
    flags = {
        status.name: {v.key: v.value for v in status.values}.get("position_uncertain") for status in found[0].status
    }
    assert any(name.endswith(": b") and flag == "true" for name, flag in flags.items()), flags
    assert any(name.endswith(": a") and flag == "false" for name, flag in flags.items()), flags
