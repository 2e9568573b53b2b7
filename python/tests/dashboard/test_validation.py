"""Every websocket command is validated server-side with the library's range checks."""

from __future__ import annotations

from typing import Any

import pytest

from nurimc.dashboard import commands as c

GOOD_BACKUP: dict[str, Any] = {
    "format": "nurimc-backup/1",
    "motors": [{"id": 1, "settings": {"position-kp": 50, "direction": "ccw", "firmware": 1}}],
}


@pytest.mark.parametrize(
    ("message", "expected"),
    [
        ({"op": "discover"}, c.Discover(None)),
        ({"op": "discover", "rates": [115200]}, c.Discover((115200,))),
        ({"op": "watch", "ids": [1, 2]}, c.Watch((1, 2))),
        ({"op": "move", "id": 1, "degrees": -90, "rpm": 60}, c.Move(1, -90.0, 60.0, None, False)),
        ({"op": "move", "id": 1, "degrees": 10, "seconds": 1, "relative": True}, c.Move(1, 10.0, None, 1.0, True)),
        ({"op": "run", "id": 2, "rpm": -30}, c.RunMotor(2, -30.0, 0.5)),
        ({"op": "release", "id": 0}, c.Release(0)),
        ({"op": "hold", "id": 254}, c.HoldMotor(254)),
        ({"op": "read_settings", "id": 3}, c.ReadSettings(3)),
        ({"op": "set", "id": 1, "name": "position_kp", "value": 77}, c.WriteSetting(1, "position-kp", 77)),
        ({"op": "set", "id": 1, "name": "direction", "value": "cw"}, c.WriteSetting(1, "direction", "cw")),
        ({"op": "step", "id": 1, "amplitude": 90}, c.Step(1, 90.0, 60.0, 2.0)),
        ({"op": "backup", "ids": [1]}, c.Backup((1,))),
        ({"op": "restore", "document": GOOD_BACKUP}, c.Restore(GOOD_BACKUP)),
        ({"op": "estop"}, c.EmergencyStop()),
        ({"op": "frames", "on": True}, c.Frames(True)),
    ],
)
def test_valid_commands_parse(message: dict[str, Any], expected: c.Command) -> None:
    assert c.parse(message) == expected


@pytest.mark.parametrize(
    ("message", "says"),
    [
        ([1, 2], "JSON object"),
        ({"op": "fly"}, "unknown op 'fly'"),
        ({"no": "op"}, "unknown op None"),
        ({"op": "move", "id": 1, "degrees": 700, "rpm": 60}, "move.degrees = 700.0 is out of range"),
        ({"op": "move", "id": 1, "degrees": 90, "rpm": 7000}, "move.rpm = 7000.0 is out of range"),
        ({"op": "move", "id": 1, "degrees": 90}, "exactly one of rpm"),
        ({"op": "move", "id": 1, "degrees": 90, "rpm": 60, "seconds": 1}, "exactly one of rpm"),
        ({"op": "move", "id": 1, "degrees": 90, "seconds": 30}, "0.1..25.5 s"),
        ({"op": "move", "id": 1, "degrees": "90", "rpm": 60}, "degrees must be a number"),
        ({"op": "move", "id": 1, "degrees": float("nan"), "rpm": 60}, "degrees must be a number"),
        ({"op": "move", "id": 1, "degrees": 9, "rpm": 60, "relative": "yes"}, "relative must be true or false"),
        ({"op": "run", "id": 1, "rpm": 0}, "speed 0 is invalid"),
        ({"op": "run", "id": 1, "rpm": 30, "ramp": 0}, "0.1..25.5 s"),
        ({"op": "release", "id": 255}, "id must be a controller ID 0..254"),
        ({"op": "release", "id": True}, "id must be a controller ID"),
        ({"op": "release", "id": "1"}, "id must be a controller ID"),
        ({"op": "release"}, "missing 'id'"),
        ({"op": "set", "id": 1, "name": "position-kp", "value": 300}, "position-kp.value = 300 is out of range"),
        ({"op": "set", "id": 1, "name": "position-kp", "value": 0}, "allowed: 1..254"),
        ({"op": "set", "id": 1, "name": "direction", "value": "up"}, "allowed: ccw or cw"),
        ({"op": "set", "id": 1, "name": "warp", "value": 1}, "unknown setting 'warp'"),
        ({"op": "set", "id": 1, "name": "firmware", "value": 2}, "firmware is read-only"),
        ({"op": "set", "id": 1, "name": "ratio", "value": True}, "ratio must be a number"),
        ({"op": "set", "id": 1, "name": "direction", "value": 1}, "direction must be one of ccw or cw"),
        ({"op": "step", "id": 1, "amplitude": 0}, "amplitude must not be 0"),
        ({"op": "step", "id": 1, "amplitude": 90, "duration": 60}, "duration must be 0.2..10.0 s"),
        ({"op": "step", "id": 1, "amplitude": 9000}, "out of range"),
        ({"op": "watch", "ids": "1,2"}, "ids must be a list"),
        ({"op": "watch", "ids": [1, 300]}, "id must be a controller ID"),
        ({"op": "discover", "rates": [12345]}, "rates must be a list of"),
        ({"op": "frames", "on": 1}, "on must be true or false"),
        ({"op": "restore", "document": {"format": "other"}}, "not a nurimc backup"),
        ({"op": "restore", "document": {"format": "nurimc-backup/1", "motors": []}}, "lists no motors"),
        (
            {"op": "restore", "document": {"format": "nurimc-backup/1", "motors": [{"id": 1, "settings": {"x": 1}}]}},
            "unknown setting 'x'",
        ),
        (
            {
                "op": "restore",
                "document": {"format": "nurimc-backup/1", "motors": [{"id": 1, "settings": {"speed-kp": 999}}]},
            },
            "speed-kp.value = 999 is out of range",
        ),
    ],
)
def test_invalid_commands_are_refused_with_a_reason(message: Any, says: str) -> None:
    with pytest.raises(c.CommandError, match=None) as raised:
        c.parse(message)
    assert says in str(raised.value)


def test_the_catalogue_lists_every_setting_with_its_range() -> None:
    catalogue = {entry["name"]: entry for entry in c.settings_catalogue()}
    assert catalogue["position-kp"]["range"] == "1..254"
    assert catalogue["direction"]["choices"] == ["ccw", "cw"]
    assert catalogue["firmware"]["writable"] is False
    assert catalogue["rated-speed"]["unit"] == "rpm"
