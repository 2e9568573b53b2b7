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


# Streams that exercise every path: whole frames, frames with one byte changed (bad checksum,
# size or mode), false headers and noise with FF and FE in it.
def _damaged(message: Message, at: int, xor: int) -> bytes:
    raw = bytearray(message.encode())
    raw[at % len(raw)] ^= xor
    return bytes(raw)


PIECE = st.one_of(
    FRAME_STRATEGY.map(lambda m: m.encode()),
    st.builds(_damaged, FRAME_STRATEGY, st.integers(2, 11), st.integers(1, 255)),
    st.binary(max_size=6),
    st.sampled_from([b"\xff", b"\xff\xfe", b"\xff\xfe\x01", b"\xff\xfe\x01\x08", b"\xff\xfe\x01\x08\x00"]),
)


@settings(max_examples=300)
@given(st.lists(PIECE, max_size=10), st.lists(st.integers(0, 10_000), max_size=8))
def test_chunking_changes_neither_frames_nor_counters(pieces: list[bytes], cuts: list[int]) -> None:
    # One byte at a time takes the careful path on every frame; whole or cut chunks mostly the fast one.
    stream = b"".join(pieces)
    whole, whole_parser = _parse_in_chunks(stream, [])
    chunked, chunked_parser = _parse_in_chunks(stream, cuts)
    one_by_one, byte_parser = _parse_in_chunks(stream, list(range(len(stream))))
    assert whole == chunked == one_by_one
    assert whole_parser.stats == chunked_parser.stats == byte_parser.stats
    assert whole_parser.stats.frames == len(whole)


def test_feed_accepts_bytearray_and_memoryview_and_copies_what_it_keeps() -> None:
    raw = make("position_feedback", 2, direction=1, position=100, speed=5, current=1).encode()
    parser = StreamParser()
    head = bytearray(raw[:7])
    assert parser.feed(head) == []
    head[:] = b"\x00" * 7  # the caller reuses its buffer: the parser must hold its own copy
    expected = make("position_feedback", 2, direction=1, position=100, speed=5, current=1)
    assert parser.feed(memoryview(raw)[7:]) == [expected]


def test_check_ranges_holds_back_out_of_range_frames_and_counts_them() -> None:
    wild = make("position_feedback", 1, direction=7, position=0xFFFF, speed=0, current=255)  # direction 7: out of range
    fine = make("position_feedback", 1, direction=1, position=10, speed=0, current=2)
    stream = _encode_unchecked(wild) + fine.encode()
    assert StreamParser().feed(stream) == [wild, fine]  # by default values come as they are
    parser = StreamParser(check_ranges=True)
    assert parser.feed(stream) == [fine]
    assert (parser.stats.out_of_range, parser.stats.frames, parser.stats.dropped_bytes) == (1, 1, 12)


def _encode_unchecked(message: Message) -> bytes:
    from nurimc.protocol import build_frame

    return build_frame(message.id, message.SPEC.mode, message.SPEC.layout.pack(*message[1:]))


def test_finish_drops_a_cut_frame_and_counts_it() -> None:
    raw = make("position_feedback", 2, direction=1, position=100, speed=5, current=1).encode()
    parser = StreamParser()
    assert parser.feed(b"\x00\x01" + raw[:9]) == []
    assert parser.pending == 9
    assert parser.finish() == []
    assert (parser.pending, parser.stats.dropped_bytes, parser.stats.frames) == (0, 11, 0)
