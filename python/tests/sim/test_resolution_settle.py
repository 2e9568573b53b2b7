"""Each product line's resolution settable, a settle rule that does not hunt between counts,
and a --state directory's values kept as stored (issue #37)."""

from __future__ import annotations

import time
from pathlib import Path

from nurimc.sim import FaultConfig, SimBus
from nurimc.sim.cli import build_bus
from tests.client.simfixtures import bus_on, virtual_sim


def test_an_rsa_moved_to_45_degrees_settles_within_a_second() -> None:
    sim = virtual_sim()
    controller = sim.add_controller(id=1, baud=115_200, product="rsa")
    with bus_on(sim, 115_200, busy_window=0.05) as bus:
        motor = bus.motor(1, "rsa")
        start = bus.clock.now()
        motor.move_to(45, rpm=30)
        state = motor.wait_until_arrived(timeout=1.0, tolerance=controller.servo.limits.quantum)
        assert bus.clock.now() - start <= 1.0
        assert abs(state.speed) < 1.0


def test_a_target_between_two_counts_does_not_hunt() -> None:
    """12 counts a turn (30 deg): 45 deg lies between 30 and 60; the servo settles on one."""
    sim = virtual_sim()
    controller = sim.add_controller(id=1, baud=115_200, product="rsa")
    controller.settings.resolution = 3  # 3 pulses x 4 = 12 counts a turn
    controller.apply_settings()
    assert controller.servo.limits.quantum == 30.0
    with bus_on(sim, 115_200, busy_window=0.05) as bus:
        motor = bus.motor(1, "rsa")
        motor.move_to(45, rpm=30)
        bus.clock.sleep(1.0)
        seen = set()
        for _ in range(20):
            bus.clock.sleep(0.05)
            seen.add(controller.logical_angle())
            assert abs(controller.servo.motor.current) < 0.1  # no drive: at rest, not fighting
        assert len(seen) == 1 and seen <= {30.0, 60.0}


def test_resolution_option_applies_to_rsa_and_rsavw(tmp_path: Path) -> None:
    bus = build_bus(
        None,
        115_200,
        ["1@115200:rsa", "2@115200:rsavw", "3@115200:blmc-h"],
        "mc",
        None,
        False,
        0,
        FaultConfig(),
        resolution=2048,
    )
    try:
        rsa, rsavw, blmc = bus.controllers
        assert rsa.counts_per_output_turn == rsavw.counts_per_output_turn == 2048 * 4
        assert blmc.counts_per_output_turn == 2048 * 3
    finally:
        bus.close()
    bus = build_bus(None, 115_200, ["1@115200:rsa"], "mc", None, False, 0, FaultConfig())
    try:
        assert bus.controllers[0].settings.resolution == 1024  # encoder-like default, not 12 counts
    finally:
        bus.close()


def test_a_stored_resolution_of_4_stays_4(tmp_path: Path) -> None:
    state = str(tmp_path / "state")
    bus = build_bus("1", 115_200, [], "mc", state, False, 0, FaultConfig())
    try:
        controller = bus.controllers[0]
        assert controller.settings.resolution == 1024  # new: the encoder-like default
        controller.settings.resolution = 4  # as if written over the wire
    finally:
        bus.close()
    bus = build_bus("1", 115_200, [], "mc", state, False, 0, FaultConfig(), resolution=2048)
    try:
        assert bus.controllers[0].settings.resolution == 4  # kept as stored, even with --resolution
    finally:
        bus.close()


def test_falling_behind_real_time_is_counted_and_said() -> None:
    sim = SimBus()
    try:
        sim.add_controller(id=1, baud=115_200)
        frame = sim.frame_time()
        assert 0.0008 < frame < 0.001  # 10 bytes at 115,200 bps
        sim.note_lag(frame / 2)  # within a frame time: on time
        assert sim.fell_behind == 0
        said: list[str] = []
        sim.say_lag = said.append  # `nurimc sim` says it on stderr
        sim.note_lag(0.05)
        sim.note_lag(0.08)
        assert sim.fell_behind == 2 and sim.worst_lag == 0.08
        assert len(said) == 1 and "fell behind real time by 50.0 ms" in said[0]  # said once, not every tick
    finally:
        sim.close()


def test_the_real_time_ticker_notices_a_stalled_physics_thread() -> None:
    """A physics step that takes 60 ms (a busy host) is counted by the background ticker."""
    sim = SimBus()
    try:
        controller = sim.add_controller(id=1, baud=115_200)
        slow = controller.advance_to

        def stalled(now: float) -> None:
            time.sleep(0.06)
            slow(now)

        controller.advance_to = stalled  # type: ignore[method-assign]
        controller.servo.static = False
        sim._start_ticker()
        end = time.monotonic() + 10
        while sim.fell_behind == 0 and time.monotonic() < end:
            controller.servo.static = False
            time.sleep(0.02)
        assert sim.fell_behind >= 1 and sim.worst_lag >= 0.03
    finally:
        sim.close()
