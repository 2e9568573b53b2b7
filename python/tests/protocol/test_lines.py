"""Product lines in the protocol layer: one frame, a message per line; a message knows its line."""

from __future__ import annotations

import pickle

import pytest

from nurimc.protocol import (
    ALL_LINES,
    DecodeError,
    SetRatedSpeed,
    StreamParser,
    UnknownLineError,
    UnknownMessageError,
    WrongLineError,
    answer_class,
    decode,
    line,
    product_line,
)

RSA_RATIO_10 = bytes.fromhex("fffe0004e809000a")  # 09 with 00 0A: built from the vendor's RSA layout


def test_the_fact_sheets_message_counts() -> None:
    counts = {key: len(line_.classes) for key, line_ in ALL_LINES.items()}
    assert counts == {"mc": 42, "rsa": 33, "rsavw": 38, "sa": 34, "sm": 18, "sm-cs": 23, "sm-readme": 22}


def test_one_frame_is_another_message_in_each_line() -> None:
    assert decode(RSA_RATIO_10) == SetRatedSpeed(0, 10)
    rsa = decode(RSA_RATIO_10, line="rsa")
    assert (rsa.name, rsa.LINE, rsa.fields()) == ("set_ratio", "rsa", {"ratio": 10})
    with pytest.raises(DecodeError) as caught:
        decode(RSA_RATIO_10, line="sm")  # SM's 09 is a factory reset, without data
    assert caught.value.kind == "size"
    with pytest.raises(UnknownLineError, match="lines: mc, rsa, rsavw, sa, sm, sm-cs, sm-readme"):
        decode(RSA_RATIO_10, line="blmc-h")


def test_a_message_belongs_to_its_line() -> None:
    release = line("rsa").make("set_control", 7, control=1)
    assert release.encode()[5] == 0x0A and line("rsa").check(release) is release
    with pytest.raises(WrongLineError, match="use MC's own set_control \\(mode 0C\\)"):
        line("mc").check(release)
    with pytest.raises(UnknownMessageError, match="it is a message of mc"):
        line("rsa").make("set_rated_speed", 7, rated_speed=100)
    with pytest.raises(UnknownMessageError):
        line("sm").make("accel_speed", 1, direction=0, speed=10, arrival_time=1)  # disputed: not in "sm"
    assert pickle.loads(pickle.dumps(release)) == release
    assert release != line("rsavw").make("set_control", 7, control=1)  # same name, another line
    assert answer_class(type(line("sm").make("request_ratio", 1))).SPEC.size == 4


def test_a_line_parser_reads_a_stream_in_its_table() -> None:
    sm = line("sm")
    stream = sm.make("ratio", 9, ratio=10).encode() + b"\x00\xff" + sm.make("control", 9, control=1).encode()
    parser = StreamParser(line="sm")
    got = [m for i in range(len(stream)) for m in parser.feed(stream[i : i + 1])]
    assert [(m.name, m.fields()) for m in got] == [("ratio", {"ratio": 10}), ("control", {"control": 1})]
    assert parser.stats.dropped_bytes == 2
    assert StreamParser().feed(stream) != got  # MC reads D4 as 6-byte speed gains: not these frames


def test_products_name_their_lines() -> None:
    assert {p: product_line(p).key for p in ("mc", "blmc-h", "rsa", "sm", "sm-cs")} == {
        "mc": "mc", "blmc-h": "mc", "rsa": "rsa", "sm": "sm", "sm-cs": "sm-cs"
    }  # fmt: skip
