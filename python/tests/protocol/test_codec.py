"""Encoding validation, decode errors, and the typed classes."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from nurimc.protocol import (
    MESSAGES,
    SPECS,
    DecodeError,
    FieldRangeError,
    FieldTypeError,
    MissingFieldError,
    PositionFeedback,
    PositionSpeed,
    RequestPosition,
    SetRatio,
    SpeedFeedback,
    UnknownFieldError,
    UnknownMessageError,
    answer_class,
    baud_index,
    checksum,
    decode,
    make,
)


def test_range_error_names_message_field_value_range_and_unit() -> None:
    with pytest.raises(FieldRangeError) as err:
        PositionSpeed(id=0, direction=0, position=18000, speed=0).encode()
    text = str(err.value)
    assert "position_speed.speed = 0" in text and "1..65533" in text and "rpm" in text
    assert err.value.field == "speed" and err.value.kind == "range"


def test_position_range_in_degrees() -> None:
    with pytest.raises(FieldRangeError, match=r"0\.0\.\.655\.33 deg"):
        PositionSpeed(id=0, direction=0, position=65534, speed=1).encode()


def test_request_cannot_be_broadcast() -> None:
    with pytest.raises(FieldRangeError, match="no broadcast"):
        RequestPosition(id=255).encode()


def test_bool_is_not_a_wire_integer() -> None:
    with pytest.raises(FieldTypeError):
        SetRatio(id=0, ratio=True).encode()


def test_make_checks_field_names() -> None:
    with pytest.raises(MissingFieldError, match="arrival_time"):
        make("accel_speed", 0, direction=0, speed=10)
    with pytest.raises(UnknownFieldError, match="colour"):
        make("set_ratio", 0, ratio=10, colour=3)
    with pytest.raises(UnknownMessageError, match="known messages"):
        make("warp", 0)


@pytest.mark.parametrize(
    ("raw", "kind"),
    [
        ("", "truncated"),
        ("00fe", "header"),
        ("fffe0002", "truncated"),
        ("fffe00025ca100", "trailing"),
        ("fffe00025da1", "checksum"),
        ("fffe0002fd00", "unknown_mode"),
        ("fffe00035ba100", "size"),
    ],
)
def test_decode_error_kinds(raw: str, kind: str) -> None:
    with pytest.raises(DecodeError) as err:
        decode(bytes.fromhex(raw))
    assert err.value.kind == kind


def test_out_of_range_values_decode_as_they_are() -> None:
    frame = PositionFeedback(id=1, direction=7, position=0xFFFF, speed=0, current=255)
    raw = bytes.fromhex("fffe0108") + bytes([checksum(1, 8, 0xD1, bytes.fromhex("07ffff0000ff")), 0xD1])
    assert decode(raw + bytes.fromhex("07ffff0000ff")) == frame


def test_physical_units_and_erratum_6() -> None:
    fb = PositionFeedback(id=0, direction=1, position=18000, speed=1234, current=12).physical()
    assert fb == {"direction": "cw", "position": 180.0, "speed": 123.4, "current": 1.2}
    # Section 20 prints the position of speed feedback in 0.1 degree: taken as printed.
    assert SpeedFeedback(id=0, direction=0, speed=0, position=1800, current=0).physical()["position"] == 180.0


def test_answer_pairing_is_request_plus_0x30() -> None:
    requests = [cls for cls in MESSAGES.values() if cls.SPEC.answer]
    assert len(requests) == 13
    for request in requests:
        expected = 0xFD if request.SPEC.mode == 0xCD else request.SPEC.mode + 0x30
        assert answer_class(request).SPEC.mode == expected


def test_baud_index() -> None:
    assert baud_index(115200) == 13 and baud_index(1_000_000) == 17
    with pytest.raises(ValueError, match="9600"):
        baud_index(9601)


def _values(name: str) -> st.SearchStrategy[dict[str, int]]:
    spec = SPECS[name]
    return st.fixed_dictionaries({f.name: st.integers(f.min, f.max) for f in spec.fields})


@given(
    st.sampled_from(sorted(SPECS)).flatmap(lambda n: st.tuples(st.just(n), _values(n), st.integers(0, SPECS[n].max_id)))
)
def test_round_trip_every_message_over_its_range(case: tuple[str, dict[str, int], int]) -> None:
    name, fields, frame_id = case
    message = make(name, frame_id, **fields)
    raw = message.encode()
    assert len(raw) == SPECS[name].size + 4
    assert decode(raw) == message


@given(st.binary(max_size=40))
def test_decode_never_raises_anything_but_decode_error(raw: bytes) -> None:
    try:
        decode(raw)
    except DecodeError as err:
        assert err.kind in {"header", "truncated", "trailing", "checksum", "unknown_mode", "size"}
