"""The smaller first-hour items of issue 38: watch's time column, record's ready line matching
its options, and the like."""

from __future__ import annotations

from .inprocess import nurimc


def test_watch_to_a_pipe_has_a_time_column() -> None:
    done = nurimc("--port", "sim://?ids=1", "--id", "1", "watch", "--count", "3", "--interval", "0.05")
    assert done.code == 0, done.err
    header, *lines = done.out.splitlines()
    assert header.split("\t")[-1] == "t (s)" and len(lines) == 3
    times = [float(line.split("\t")[-1]) for line in lines]
    assert times == sorted(times) and times[-1] - times[0] >= 0.1  # two intervals of 0.05 s at least
