"""The stream parser: chunking, noise, resynchronisation, bounded memory."""

from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st

from nurimc.protocol import SPECS, Message, StreamParser, make

FRAME_STRATEGY = st.sampled_from(sorted(SPECS)).flatmap(
    lambda n: st.builds(
        lambda fields, frame_id: make(n, frame_id, **fields),
        st.fixed_dictionaries({f.name: st.integers(f.min, f.max) for f in SPECS[n].fields}),
        st.integers(0, SPECS[n].max_id),
    )
)


def _parse_in_chunks(stream: bytes, cuts: list[int]) -> tuple[list[Message], StreamParser]:
    parser = StreamParser()
    frames: list[Message] = []
    bounds = [0, *sorted(c % (len(stream) + 1) for c in cuts), len(stream)]
    for a, b in itertools.pairwise(bounds):
        frames += parser.feed(stream[a:b])
        assert parser.pending <= 12  # bounded: at most one frame's worth held back
    frames += parser.finish()
    return frames, parser


@settings(max_examples=300)
@given(st.lists(FRAME_STRATEGY, max_size=8), st.lists(st.integers(0, 10_000), max_size=10))
def test_frames_survive_any_chunking(messages: list[Message], cuts: list[int]) -> None:
    stream = b"".join(m.encode() for m in messages)
    frames, parser = _parse_in_chunks(stream, cuts)
    assert frames == messages
    assert parser.stats.dropped_bytes == 0


# Noise that cannot contain FF: no header can start inside it, so every real frame must come out.
NOISE = st.binary(max_size=12).map(lambda b: b.replace(b"\xff", b"\x00"))


@settings(max_examples=300)
@given(
    st.lists(st.tuples(NOISE, FRAME_STRATEGY), max_size=6),
    NOISE,
    st.lists(st.integers(0, 10_000), max_size=6),
)
def test_frames_recovered_between_noise(parts: list[tuple[bytes, Message]], tail: bytes, cuts: list[int]) -> None:
    stream = b"".join(noise + m.encode() for noise, m in parts) + tail
    frames, parser = _parse_in_chunks(stream, cuts)
    assert frames == [m for _, m in parts]
    assert parser.stats.dropped_bytes == sum(len(n) for n, _ in parts) + len(tail)


@settings(max_examples=300)
@given(st.binary(max_size=300), st.lists(st.integers(0, 10_000), max_size=10))
def test_random_bytes_never_raise_and_are_accounted(stream: bytes, cuts: list[int]) -> None:
    frames, parser = _parse_in_chunks(stream, cuts)
    consumed = sum(len(m.encode()) if _in_range(m) else m.SPEC.size + 4 for m in frames)
    assert consumed + parser.stats.dropped_bytes == len(stream)
    assert parser.pending == 0


def _in_range(message: Message) -> bool:
    return (
        all(f.min <= getattr(message, f.name) <= f.max for f in message.SPEC.fields)
        and message.id <= message.SPEC.max_id
    )


def test_false_header_does_not_hide_the_frame_behind_it() -> None:
    real = make("ping", 3).encode()
    parser = StreamParser()
    assert parser.feed(b"\xff\xfe\x00\x08" + real) == [make("ping", 3)]
    assert parser.stats.dropped_bytes == 4


def test_incomplete_frame_waits_then_completes() -> None:
    raw = make("position_feedback", 2, direction=1, position=100, speed=5, current=1).encode()
    parser = StreamParser()
    assert parser.feed(raw[:7]) == []
    assert parser.pending == 7
    assert parser.feed(raw[7:]) == [make("position_feedback", 2, direction=1, position=100, speed=5, current=1)]


def test_diagnostics_are_counted() -> None:
    good = make("request_ping", 1).encode()
    bad_sum = good[:4] + bytes([good[4] ^ 1]) + good[5:]
    parser = StreamParser()
    parser.feed(bad_sum + b"\xff\xfe\x00\x02\x00\x42" + b"\xff\xfe\x00\x03\x00\xa0\x00" + b"\x11\x22")
    parser.finish()
    s = parser.stats
    assert (s.bad_checksum, s.unknown_mode, s.bad_size, s.frames) == (1, 1, 1, 0)
    assert s.dropped_bytes == 6 + 6 + 7 + 2
