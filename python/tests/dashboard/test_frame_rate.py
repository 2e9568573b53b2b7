"""frames/s on the status bar from the bus's own counters and clock (issue #37): never above
what the wire can carry, whenever the figures reach the page."""

from __future__ import annotations

from nurimc.dashboard.busstats import FrameRate, bus_stats
from tests.client.simfixtures import sim_bus

BAUD = 115_200


def test_frames_per_second_never_exceeds_the_wire() -> None:
    """Poll as fast as the wire allows (wire timing on, virtual time) and read the stats at
    uneven moments, some in bursts (as a busy page would take its ticks): every figure is at
    most the wire's maximum, and over a second it is what went on the wire."""
    _sim, bus = sim_bus([1, 2, 3], baud=BAUD, wire_timing=True, resolution=1024)
    with bus:
        rate = FrameRate(clock=bus.clock.now)
        motors = [bus.motor(i) for i in (1, 2, 3)]
        # the shortest frame is 6 bytes of 10 bits: no more frames than this fit in a second
        wire_max = BAUD / (10 * 6)
        figures = []
        start = bus.stats.requests + bus.stats.answers
        began = bus.clock.now()
        for turn in range(600):
            motors[turn % 3].read_state()
            if turn % 50 in (0, 1, 2):  # three reads back to back, then a pause
                stats = bus_stats(bus, rate)
                assert stats is not None
                if stats["frames_per_second"] is not None:
                    figures.append(stats["frames_per_second"])
        elapsed = bus.clock.now() - began
        true_rate = (bus.stats.requests + bus.stats.answers - start) / elapsed
        assert figures and max(figures) <= wire_max
        assert abs(figures[-1] - true_rate) <= 0.25 * true_rate


def test_the_rate_is_over_the_window_on_its_own_clock() -> None:
    now = [0.0]
    rate = FrameRate(window=1.0, clock=lambda: now[0])
    assert rate.update(0) is None
    now[0] = 0.5
    assert rate.update(500) == 1000.0
    now[0] = 0.5  # the same moment again (two ticks at once): no division by zero, no spike
    assert rate.update(500) == 1000.0
    now[0] = 2.0
    # from the newest count at least a window old: (1500 - 500) / (2.0 - 0.5)
    assert rate.update(1500) == 1000 / 1.5
    now[0] = 3.0
    assert rate.update(2500) == 1000.0
