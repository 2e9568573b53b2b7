"""The explaining parser: the same frames as the stream parser, and a reason for the rest."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.protocol import StreamParser, make
from nurimc.protocol.sniff import ExplainingParser, Rejected, SniffedFrame, Sniffer

PING = make("request_ping", 3).encode()
MOVE = make("position_speed", 1, direction=0, position=9000, speed=100).encode()

pieces = st.one_of(
    st.sampled_from([PING, MOVE, make("ping", 3).encode(), b"\xff\xfe", b"\xff", b"\xff\xfe\x01\x08"]),
    st.binary(max_size=12),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(pieces, max_size=12), st.lists(st.integers(1, 20), min_size=1, max_size=8))
def test_takes_exactly_the_frames_the_stream_parser_takes(parts: list[bytes], cuts: list[int]) -> None:
    data = b"".join(parts)
    reference = StreamParser()
    expected = reference.feed(data) + reference.finish()
    explaining, events, pos = ExplainingParser(), [], 0
    for cut in cuts * (len(data) // max(1, sum(cuts)) + 1):
        events += explaining.feed(data[pos : pos + cut])
        pos += cut
    events += explaining.feed(data[pos:]) + explaining.finish()
    assert [e.message for e in events if isinstance(e, SniffedFrame)] == expected


def test_says_why_a_candidate_is_no_frame() -> None:
    bad_sum = bytearray(MOVE)
    bad_sum[4] ^= 0xFF
    unknown = b"\xff\xfe\x02\x02\x00\x55"
    wrong_size = b"\xff\xfe\x02\x03\x00\xa0\x00"
    events = ExplainingParser().feed(bytes(bad_sum) + unknown + wrong_size + b"\x01\x02" + PING)
    reasons = [e.reason for e in events if isinstance(e, Rejected)]
    assert reasons[0].startswith("bad checksum") and "position_speed" in reasons[0]
    assert reasons[1].startswith("unknown mode 0x55")
    assert reasons[2].startswith("wrong size 3 for request_ping")
    assert any("outside any frame" in r for r in reasons)
    assert isinstance(events[-1], SniffedFrame) and events[-1].raw == PING
    # each rejected candidate is reported once, not once per byte dropped
    assert sum(r.startswith("bad checksum") for r in reasons) == 1


def test_sniffer_tells_direction_and_time() -> None:
    sniffer = Sniffer()
    heard = sniffer.feed(make("request_position", 1).encode(), 0.5) + sniffer.feed(
        make("position_feedback", 1, direction=0, position=9000, speed=0, current=0).encode(), 0.6
    )
    assert [h.direction for h in heard] == ["host -> id 1", "id 1 -> host"]
    assert heard[0].to_dict()["message"] == "request_position" and heard[1].t == 0.6
    assert "host -> id 1" in heard[0].text()
