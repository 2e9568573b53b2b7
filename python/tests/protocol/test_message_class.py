"""The generated message classes behave as frozen value classes (they are tuples underneath, for speed)."""

from __future__ import annotations

import copy
import pickle

import pytest

from nurimc.protocol import FieldRangeError, Ping, PositionFeedback, RequestPing, SpeedFeedback


def test_fields_by_name_keyword_and_positional() -> None:
    a = PositionFeedback(id=1, direction=0, position=18000, speed=12, current=3)
    assert (a.id, a.direction, a.position, a.speed, a.current) == (1, 0, 18000, 12, 3)
    assert a == PositionFeedback(1, 0, 18000, 12, 3)
    with pytest.raises(TypeError):
        PositionFeedback(1, 0, 18000, 12)  # type: ignore[call-arg]


def test_equal_only_to_the_same_class_with_the_same_values() -> None:
    a = PositionFeedback(id=1, direction=0, position=5, speed=6, current=7)
    assert a != SpeedFeedback(id=1, direction=0, speed=5, position=6, current=7)  # same numbers, other message
    plain = (1, 0, 5, 6, 7)
    assert a != plain
    assert plain != a  # the reflected comparison
    assert (a == plain) is False
    assert Ping(3) != RequestPing(3)
    assert a != PositionFeedback(id=2, direction=0, position=5, speed=6, current=7)
    assert hash(a) == hash(PositionFeedback(id=1, direction=0, position=5, speed=6, current=7))
    assert len({a, PositionFeedback(1, 0, 5, 6, 7)}) == 1


def test_immutable_and_unordered() -> None:
    a = Ping(id=3)
    with pytest.raises(AttributeError):
        a.id = 4
    with pytest.raises(AttributeError):
        a.colour = 1  # type: ignore[attr-defined]
    with pytest.raises(TypeError):
        _ = a < Ping(id=4)  # mypy sees a tuple; the class refuses ordering at run time


def test_repr_copy_pickle_and_match() -> None:
    a = PositionFeedback(id=1, direction=1, position=2, speed=3, current=4)
    assert repr(a) == "PositionFeedback(id=1, direction=1, position=2, speed=3, current=4)"
    assert copy.copy(a) == a and copy.deepcopy(a) == a
    assert pickle.loads(pickle.dumps(a)) == a
    match a:
        case PositionFeedback(_, _, position):
            assert position == 2
        case _:
            pytest.fail("no match")


def test_check_on_request() -> None:
    fine = PositionFeedback(id=1, direction=1, position=2, speed=3, current=4)
    assert fine.check() is fine
    with pytest.raises(FieldRangeError, match="direction"):
        PositionFeedback(id=1, direction=7, position=2, speed=3, current=4).check()
