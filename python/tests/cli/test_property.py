"""Issue #12 point 6: generated values for every numeric CLI option and every backup field.

Whatever the value (inf, nan, huge, negative, empty, unicode, wrong type), `nurimc` ends with
exit 0, 1 or 2, no traceback, and at most one error line (exactly one when it fails). Numbers are
refused before the bus is touched: the calls name a port that does not exist, so exit 1 (port
not found) means the value was accepted and exit 2 that it was refused, and for the options
with a plain range the test knows, from its own reading of the range, which it must be.
In-process (inprocess.py), so a few hundred calls take seconds.
"""

from __future__ import annotations

import inspect
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurimc.cli.app import app, main_options
from nurimc.procedures import backup
from nurimc.procedures.settings import SETTINGS
from nurimc.protocol import BAUD_RATES, SPECS
from nurimc.protocol.host import LIMITS

from .inprocess import assert_clean, nurimc

NO_PORT = "/dev/nurimc-no-such-port"  # exit 1 once a value is accepted: the port is missing
ACCEPTED, REFUSED = 1, 2

#: Text a person (or a script gone wrong) may type where a number belongs.
SPECIAL = [
    *("inf", "-inf", "+inf", "Infinity", "nan", "NaN", "-nan", "1e400", "-1e400", "1e309", "4.9e-324", "1e-400"),
    *("99999999999999999999999", "-99999999999999999999999", "9" * 5000, "-1", "-0", "0", "0.0", "-0.0"),
    *("", " ", "\t", "1 ", " 1", "1.5", "2.5", "0.05", "0.049", "0x10", "1_000", "1,5", "1e3", "1E3", ".5", "5."),
    *(
        "true",
        "false",
        "null",
        "None",
        "[1]",
        "{}",
        "'1'",
        '"1"',
        "1/2",
        "½",
        "¹",
        "Ⅻ",
        "١٢",
        "\uff11\uff12",
        "1\u00a0",
    ),
    *("é", "∞", "-∞", "90°", "100rpm", "300us", "2.5A", "12.5:1", "\x00", "1\n2", "🙂"),
]
#: Flags the parser reads as options wherever they are (a value is never one of them).
NOT_A_VALUE = {"-v", "-h", "--help", "--verbose", "--json", "--version", "--"}


def is_value(text: str) -> bool:
    return text not in NOT_A_VALUE and not text.startswith("--")


VALUES = st.one_of(
    st.sampled_from(SPECIAL),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(min_value=-1e6, max_value=1e6).map(lambda x: f"{x:.3f}"),
    st.integers(min_value=-(10**30), max_value=10**30).map(str),
    st.text(max_size=10),
).filter(is_value)
PROPERTY = settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def plain_number(text: str) -> float | None:
    """Our own reading of a typed number: ASCII digits (space around it is fine), finite, what
    Python's float() reads; else None."""
    text = text.strip()
    if not text or not text.isascii():
        return None
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def in_range(low: float, high: float, *, whole: bool = False) -> Callable[[str], bool]:
    def accepts(text: str) -> bool:
        value = plain_number(text)
        return value is not None and low <= value <= high and (not whole or value.is_integer())

    return accepts


POSITION, RPM_MIN, RPM_MAX = LIMITS["position_deg"], LIMITS["speed_rpm_min"], LIMITS["speed_rpm_max"]
SECONDS = in_range(LIMITS["arrival_s_min"], LIMITS["arrival_s_max"])


def one_rate(text: str) -> bool:
    value = plain_number(text)
    return value is not None and value in BAUD_RATES


def one_id(text: str) -> bool:
    return in_range(0, 254, whole=True)(text) and "," not in text


#: Every numeric option and argument: (its name, the call with V for the value, what it accepts,
#: or None where the answer is not a plain range: lists, units, rounding to a step that can reach 0).
NUMERIC: list[tuple[str, list[str], Callable[[str], bool] | None]] = [
    ("--baud", ["--port", NO_PORT, "--baud", "V", "--id", "1", "ping"], one_rate),
    ("--id", ["--port", NO_PORT, "--id", "V", "ping"], None),  # 1,2 and 0-3 are IDs too
    ("move degrees", ["--port", NO_PORT, "--id", "1", "move", "V"], in_range(-POSITION, POSITION)),
    ("move --rpm", ["--port", NO_PORT, "--id", "1", "move", "90", "--rpm", "V"], in_range(RPM_MIN, RPM_MAX)),
    ("move --seconds", ["--port", NO_PORT, "--id", "1", "move", "90", "--seconds", "V"], SECONDS),
    ("run rpm", ["--port", NO_PORT, "--id", "1", "run", "V"], None),  # |rpm| >= 0.1 after rounding
    ("run --ramp", ["--port", NO_PORT, "--id", "1", "run", "100", "--ramp", "V"], SECONDS),
    ("move --timeout", ["--port", NO_PORT, "--id", "1", "move", "90", "--wait", "--timeout", "V"], in_range(0.1, 3600)),
    ("stop --ramp", ["--port", NO_PORT, "--id", "1", "stop", "--ramp", "V"], SECONDS),
    # tune (issue 35): refusals before the port is opened; --travel's smallest depends on the loop
    ("tune --max-overshoot", ["--port", NO_PORT, "--id", "1", "tune", "--max-overshoot", "V"], in_range(0, 100)),
    ("tune --max-settling", ["--port", NO_PORT, "--id", "1", "tune", "--max-settling", "V"], in_range(0.01, 30)),
    ("tune --travel", ["--port", NO_PORT, "--id", "1", "tune", "--travel", "V"], None),
    ("tune --max-rpm", ["--port", NO_PORT, "--id", "1", "tune", "--max-rpm", "V"], in_range(1, 6553.3)),
    ("tune --max-current", ["--port", NO_PORT, "--id", "1", "tune", "--max-current", "V"], in_range(0.1, 25.4)),
    ("tune --trials", ["--port", NO_PORT, "--id", "1", "tune", "--trials", "V"], in_range(2, 500, whole=True)),
    ("watch --interval", ["--port", NO_PORT, "--id", "1", "watch", "--interval", "V"], in_range(0.01, 3600)),
    ("watch --count", ["--port", NO_PORT, "--id", "1", "watch", "--count", "V"], in_range(0, 1e6, whole=True)),
    ("scan --rates", ["--port", NO_PORT, "scan", "--rates", "V"], None),  # a list
    ("scan --ids", ["--port", NO_PORT, "scan", "--ids", "V"], None),  # a list
    ("scan --expect", ["--port", NO_PORT, "scan", "--expect", "V"], in_range(0, 255 * 18, whole=True)),
    ("sniff --duration", ["--port", NO_PORT, "sniff", "--duration", "V"], in_range(0, 86400)),
    ("encode --to", ["encode", "request_ping", "--to", "V"], in_range(0, 255, whole=True)),
    ("demo --seconds", ["demo", "--seconds", "V"], in_range(0, 3600)),
    ("ros2 --rate", ["--port", NO_PORT, "ros2", "--ids", "1", "--rate", "V"], in_range(0, 10_000)),
    ("ros2 --seconds", ["--port", NO_PORT, "ros2", "--ids", "1", "--seconds", "V"], in_range(0.01, 1e6)),
    ("ros2 --command-timeout", ["--port", NO_PORT, "ros2", "--ids", "1", "--command-timeout", "V"], in_range(0, 3600)),
    ("ros2 --move-velocity", ["--port", NO_PORT, "ros2", "--ids", "1", "--move-velocity", "V"], None),  # 4 digits
    ("ros2 --ramp", ["--port", NO_PORT, "ros2", "--ids", "1", "--ramp", "V"], SECONDS),
    (
        "ros2 --wheel-radius",
        ["--port", NO_PORT, "ros2", "--diff-drive", "1,2", "--wheel-separation", "0.4", "--wheel-radius", "V"],
        in_range(0.001, 10),
    ),
    (
        "ros2 --wheel-separation",
        ["--port", NO_PORT, "ros2", "--diff-drive", "1,2", "--wheel-radius", "0.1", "--wheel-separation", "V"],
        in_range(0.001, 100),
    ),
    (
        "ros2 --max-linear",
        [
            "--port",
            NO_PORT,
            "ros2",
            "--diff-drive",
            "1,2",
            "--wheel-radius",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--max-linear",
            "V",
        ],
        in_range(0.001, 100),
    ),
    (
        "ros2 --max-angular",
        [
            "--port",
            NO_PORT,
            "ros2",
            "--diff-drive",
            "1,2",
            "--wheel-radius",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--max-angular",
            "V",
        ],
        in_range(0.001, 100),
    ),
    (
        "ros2 --max-linear-accel",
        [
            "--port",
            NO_PORT,
            "ros2",
            "--diff-drive",
            "1,2",
            "--wheel-radius",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--max-linear-accel",
            "V",
        ],
        in_range(0.001, 100),
    ),
    (
        "ros2 --max-angular-accel",
        [
            "--port",
            NO_PORT,
            "ros2",
            "--diff-drive",
            "1,2",
            "--wheel-radius",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--max-angular-accel",
            "V",
        ],
        in_range(0.001, 100),
    ),
    ("record --rate", ["--port", NO_PORT, "record", "--mcap", "{tmp}/r.mcap", "--rate", "V"], in_range(0, 10_000)),
    ("record --seconds", ["--port", NO_PORT, "record", "--mcap", "{tmp}/r.mcap", "--seconds", "V"], None),
    (
        "record --checkpoint",
        ["--port", NO_PORT, "record", "--mcap", "{tmp}/r.mcap", "--checkpoint", "V"],
        in_range(0.05, 60),
    ),
    (
        "record --port-wait",
        ["--port", NO_PORT, "record", "--mcap", "{tmp}/r.mcap", "--port-wait", "V"],
        in_range(0, 3600),
    ),
    ("set id", ["--port", NO_PORT, "--id", "1", "set", "id", "V"], in_range(0, 254, whole=True)),
    ("set baud", ["--port", NO_PORT, "--id", "1", "set", "baud", "V"], one_rate),
    *[(f"set {name}", ["--port", NO_PORT, "--id", "1", "set", name, "V"], None) for name in SETTINGS],
    *[
        (f"encode {spec.name}.{f.name}", ["encode", spec.name, f"{f.name}=V"], None)
        for spec in SPECS.values()
        for f in spec.fields
    ],
]
#: Long-running commands: when a value is accepted they would run; only refusals are run here.
ONLY_REFUSALS = ("demo --seconds",)
#: Commands whose numbers are the simulator's (its owner checks them, issue #12 point 5).
NOT_HERE = {"sim"}


#: Parameters whose option is not their name with dashes.
OPTION_NAMES = {"device_id": "--to"}


def _float_like(annotation: object) -> bool:
    return any(kind in str(annotation) for kind in ("float", "int"))


def test_the_table_names_every_numeric_option() -> None:
    """A new numeric option must join NUMERIC (and so the property below)."""
    listed = " | ".join(name for name, _, _ in NUMERIC)
    missing = []
    for command in app.registered_commands:
        assert command.callback is not None
        name = command.name or command.callback.__name__.rstrip("_")
        if name in NOT_HERE:
            continue
        for parameter in inspect.signature(command.callback).parameters.values():
            option = OPTION_NAMES.get(parameter.name, "--" + parameter.name.replace("_", "-"))
            known = f"{name} {option}" in listed or f"{name} {parameter.name}" in listed
            if _float_like(parameter.annotation) and not known:
                missing.append(f"{name} {parameter.name}")
    assert missing == []
    assert "--baud" in listed and "--id" in listed  # the global ones are text parsed as numbers
    assert {"baud", "ids"} <= set(inspect.signature(main_options).parameters)
    for setting_name in SETTINGS:
        assert f"set {setting_name}" in listed


def _call(template: list[str], value: str, tmp: Path) -> list[str]:
    def fill(part: str) -> str:
        if part == "V":
            return value
        if part.endswith("=V"):  # encode's field=value
            return part[:-1] + value
        return part.replace("{tmp}", str(tmp))

    return [fill(part) for part in template]


@pytest.mark.parametrize(("name", "template", "accepts"), NUMERIC, ids=[n for n, _, _ in NUMERIC])
@PROPERTY
@given(value=VALUES)
def test_every_numeric_option(
    name: str, template: list[str], accepts: Callable[[str], bool] | None, value: str, tmp_path: Path
) -> None:
    argv = _call(template, value, tmp_path)
    expected = None if accepts is None else accepts(value)
    if name in ONLY_REFUSALS and expected is not False:
        return
    result = nurimc(*argv)
    assert_clean(result, *argv)
    ok_code = 0 if template[0] == "encode" else ACCEPTED
    assert result.code in (ok_code, REFUSED), f"{name} = {value!r}: exit {result.code}: {result.err!r}"
    if expected is not None:
        assert result.code == (ok_code if expected else REFUSED), f"{name} = {value!r}: {result.err!r}"


# -- backup files ------------------------------------------------------------------------------

JSON_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**40), max_value=10**40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.sampled_from(["", " ", "\uff11\uff12", "12.5", "cw", "CW", "on", "mc", "blmc-h", "nurimc-backup/1", "🙂"]),
)
JSON_VALUES = st.recursive(
    JSON_SCALARS,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=6,
)
GOOD_MOTOR = {"id": 1, "baudrate": 9600, "product": "mc", "settings": {"position-kp": 50, "ratio": 12.5}}
GOOD = {"format": backup.FORMAT, "protocol": "MC-RS485 V1.0.1", "time": "2026-11-23T10:00:00Z", "motors": [GOOD_MOTOR]}
#: Every field a backup holds: where it sits, and a name the refusal must give.
TOP_FIELDS = ["format", "protocol", "time", "motors", "unknown-field"]
MOTOR_FIELDS = ["id", "baudrate", "product", "settings", "unknown-field"]


def _with(document: dict[str, Any], path: tuple[str, ...], value: object) -> dict[str, Any]:
    copy: dict[str, Any] = json.loads(json.dumps(document))
    where: Any = copy
    for key in path[:-1]:
        where = where["motors"][0] if key == "motors[0]" else where[key]
    where[path[-1]] = value
    return copy


FIELD_PATHS = [
    *[(f,) for f in TOP_FIELDS],
    *[("motors[0]", f) for f in MOTOR_FIELDS],
    *[("motors[0]", "settings", name) for name in SETTINGS],
]


def test_every_setting_is_a_backup_field() -> None:
    assert {p[-1] for p in FIELD_PATHS if len(p) == 3} == set(SETTINGS)


def _restore(tmp: Path, document: object) -> tuple[Any, Path]:
    path = tmp / "backup.json"
    path.write_text(json.dumps(document, allow_nan=True), encoding="utf-8")
    return nurimc("--port", NO_PORT, "restore", str(path)), path


@pytest.mark.parametrize("field", FIELD_PATHS, ids=[".".join(p) for p in FIELD_PATHS])
@PROPERTY
@given(value=JSON_VALUES)
def test_every_backup_field(field: tuple[str, ...], value: object, tmp_path: Path) -> None:
    document = _with(GOOD, field, value)
    try:
        backup.check(document, "file.json")
        checked = True
    except backup.BackupError as error:  # nothing else may escape: no TypeError, no KeyError
        checked = False
        message = str(error)
        assert "\n" not in message and message.startswith("file.json: ")
        if field[0] == "motors[0]" and field[-1] != "id":
            assert "motors[0]" in message and "(ID 1)" in message, message  # which motor
        if len(field) == 3:
            assert f"settings.{field[-1]}" in message, message  # which field
    result, path = _restore(tmp_path, document)
    assert_clean(result, "restore", str(path))
    assert result.code == (ACCEPTED if checked else REFUSED), result.err
    if not checked:
        assert result.errors[0].startswith(f"error: {path}: "), result.err  # which file


@PROPERTY
@given(document=JSON_VALUES)
def test_any_json_document_is_refused_in_one_line(document: object, tmp_path: Path) -> None:
    result, path = _restore(tmp_path, document)
    assert_clean(result, "restore", str(path))
    assert result.code == REFUSED and result.errors[0].startswith(f"error: {path}: ")
