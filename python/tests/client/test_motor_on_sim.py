"""Motors, settings, groups, discovery and configuration against the in-process simulator."""

from __future__ import annotations

import itertools
import json
import threading
from collections.abc import Iterator

import pytest

from nurimc import ConfirmationRequired, CorruptedAnswer, Group, IdInUse, NoAnswer, SettingNotApplied
from nurimc.procedures import config as cfg
from nurimc.procedures.discovery import Progress, discover
from nurimc.procedures.settings import SETTINGS
from nurimc.protocol import BAUD_RATES, FieldRangeError, PositionFeedback, RequestPosition
from nurimc.sim import FaultConfig
from nurimc.transport.trafficlog import replay

from .simfixtures import sim_bus, wait_until


@pytest.fixture
def one() -> Iterator:  # type: ignore[type-arg]
    sim, bus = sim_bus([1], resolution=1000)
    yield bus
    bus.close()
    sim.close()


def test_move_to_settles_at_the_target(one) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    motor.move_to(90, rpm=120)
    assert wait_until(one, lambda: abs(motor.read_state().position - 90) < 0.5)
    motor.move_to(-45, seconds=0.5)
    assert wait_until(one, lambda: abs(motor.read_state().position + 45) < 0.5)
    assert motor.read_state().direction == "cw"


def test_move_by_in_absolute_and_relative_mode(one) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    motor.move_by(30, rpm=120)
    assert wait_until(one, lambda: abs(motor.read_state().position - 30) < 0.5)
    motor.set("position-mode", "relative")
    motor.move_by(20, rpm=120)
    assert wait_until(one, lambda: abs(motor.read_state().position - 50) < 0.5)
    motor.move_to(10, rpm=120)  # absolute target even though the device is in relative mode
    assert wait_until(one, lambda: abs(motor.read_state().position - 10) < 0.5)


def test_run_release_and_hold(one) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    motor.run(-60, ramp_seconds=0.1)
    assert wait_until(one, lambda: motor.read_speed() < -50)
    motor.release()
    assert motor.get("control") == "off"
    assert wait_until(one, lambda: abs(motor.read_speed()) < 1)
    motor.hold()
    assert motor.get("control") == "on"
    with pytest.raises(FieldRangeError, match="release"):
        motor.run(0)


def test_position_is_continuous_across_wraps(one) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    motor.run(300, ramp_seconds=0.1)  # 1800 deg/s: a wrap every 0.36 s
    readings = []
    end = one.clock.now() + 1.2
    while one.clock.now() < end:
        readings.append(motor.read_state().position)
        one.clock.sleep(0.03)
    motor.release()
    assert readings[-1] > 655.36  # went past the device's wrap...
    assert all(b >= a - 1 for a, b in itertools.pairwise(readings))  # ...without jumping back


@pytest.mark.parametrize("name", [n for n, s in SETTINGS.items() if s.command and n != "control"])
def test_every_setting_round_trips_verified(one, name: str) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    before = motor.get(name)
    value = {
        "direction": "cw",
        "position-mode": "relative",
        "response-time": 300,
        "ratio": 12.5,
        "resolution": 13,
        "rated-speed": 2000,
    }.get(name, 3 if not name.endswith("current") else 2.5)
    assert motor.set(name, value) == value
    assert motor.get(name) == value != before


def test_setting_out_of_range_is_refused_before_sending(one) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(FieldRangeError, match=r"0\.1\.\.6553\.3"):
        one.motor(1).set("ratio", 0)


def test_group_commands_and_reads(one) -> None:  # type: ignore[no-untyped-def]
    sim, bus = sim_bus([1, 2, 3], baud=115200, resolution=1000)
    group = Group(bus, [1, 2, 3])
    group.command([m.make_move_to(10.0 * m.id, rpm=200) for m in group.motors])
    assert wait_until(bus, lambda: all(abs(s.position - 10 * i) < 0.5 for i, s in group.read_states().items()))
    slot = group.stagger()
    states = group.read_states_broadcast()
    assert sorted(states) == [1, 2, 3] and slot >= 1
    assert all(abs(states[i].position - 10 * i) < 0.5 for i in states)
    bus.close()
    sim.close()


def test_discovery_finds_controllers_at_several_rates() -> None:
    sim, bus = sim_bus({4: 9600, 17: 115200, 200: 1_000_000}, baud=57600)
    events: list[Progress] = []
    found = bus.run(discover(bus.core), on_note=events.append)
    assert sorted((f.id, f.baudrate) for f in found) == [(4, 9600), (17, 115200), (200, 1_000_000)]
    assert all(f.firmware is not None for f in found)
    assert len({e.rate for e in events}) == 18 and bus.baudrate == 57600
    bus.close()
    sim.close()


def test_discovery_walks_ids_when_answers_collide() -> None:
    sim, bus = sim_bus([5, 6, 7])  # same default response time: the broadcast answers collide
    events: list[Progress] = []
    found = bus.run(discover(bus.core, rates=[9600]), on_note=events.append)
    assert sorted(f.id for f in found) == [5, 6, 7]
    assert any(e.walking_id is not None for e in events)  # it had to walk the IDs
    bus.close()
    sim.close()


def test_controllers_sharing_a_rate_are_found_at_the_pace_of_the_wire() -> None:
    """8 controllers at 9600 bps at unknown IDs, all 18 rates searched, on virtual time (so the
    figure is the protocol's, not this host's): within 1.5x the wire floor, and never a write.
    The floor here is stricter than benchmarks/wire_bench.py's: per walked ID a request plus the
    wait in which an answer would have begun, and per other rate a broadcast ping plus that wait
    at the controllers' default response time (not the longest one a controller may have)."""
    ids = [3, 17, 40, 41, 99, 150, 201, 254]
    sim, bus = sim_bus(ids, wire_timing=True)
    bus.baudrate = 115200
    sent: list[bytes] = []
    bus.add_listener(
        type(
            "Tx",
            (),
            {"record": lambda self, d, data: sent.append(data) if d == "tx" else None, "close": lambda self: None},
        )()
    )
    start = bus.clock.now()
    found = bus.run(discover(bus.core))
    seconds = bus.clock.now() - start
    assert [(f.id, f.baudrate) for f in found] == [(i, 9600) for i in ids]
    char = {r: 10 / r for r in BAUD_RATES}
    response = 100e-6  # the controllers' (default) response time
    floor = 255 * (6 * char[9600] + response + char[9600]) + len(ids) * 6 * char[9600]
    floor += sum(6 * char[r] + response + char[r] for r in BAUD_RATES if r != 9600)
    assert seconds <= 1.5 * floor, (seconds, floor)
    assert len(sent) > 255  # the walk went out on the wire ...
    modes = {mode for data in sent for mode in frame_modes(data)}
    # ... pings and firmware requests, and per controller found its product line's question (AB
    # answered: MC; nurimc.procedures.products): requests only, never a command (no write)
    assert {0xA0, 0xCD} <= modes <= {0xA0, 0xCD, 0xAB}
    bus.close()
    sim.close()


def frame_modes(data: bytes) -> list[int]:
    """The mode byte of each frame in `data` (FF FE id length checksum mode ...)."""
    modes, i = [], 0
    while i < len(data):
        assert data[i : i + 2] == b"\xff\xfe"
        modes.append(data[i + 5])
        i += data[i + 3] + 4
    return modes


def test_duplicate_ids_are_reported_as_corrupted_not_misread() -> None:
    sim, bus = sim_bus([2, 3], resolution=1000)
    # both away from 0: an all-zero answer is dominant on the wire and can survive a collision whole
    bus.motor(2).move_to(-70, rpm=300)
    bus.motor(3).move_to(40, rpm=300)
    bus.clock.sleep(0.4)
    bus.run(cfg.change_id(bus.core, 3, 4))
    sim.controllers[1].settings.id = 2  # a second controller at ID 2, behind the library's back
    with pytest.raises(CorruptedAnswer, match=r"same ID|collid|noise"):
        bus.motor(2).read_state()
    bus.close()
    sim.close()


def test_change_id_refuses_a_taken_id_and_verifies() -> None:
    sim, bus = sim_bus([1, 2])
    with pytest.raises(IdInUse):
        bus.run(cfg.change_id(bus.core, 1, 2))
    bus.run(cfg.change_id(bus.core, 1, 9))
    assert bus.motor(9).ping()
    with pytest.raises(NoAnswer):
        bus.motor(1).ping()
    bus.close()
    sim.close()


def test_change_baud_moves_controller_and_host() -> None:
    sim, bus = sim_bus([1])
    assert bus.run(cfg.change_baud(bus.core, 1, 115200)) == 115200
    assert bus.baudrate == 115200 and bus.motor(1).ping()
    bus.baudrate = 9600
    with pytest.raises(NoAnswer):
        bus.motor(1).ping()
    bus.close()
    sim.close()


def test_factory_reset_needs_confirmation() -> None:
    sim, bus = sim_bus([3])
    with pytest.raises(ConfirmationRequired, match="--yes"):
        bus.run(cfg.factory_reset(bus.core, 3))
    bus.motor(3).set("ratio", 5)
    bus.run(cfg.factory_reset(bus.core, 3, confirm=True))
    bus.clock.sleep(0.05)
    assert bus.motor(0).get("ratio") == 1.0  # back to defaults, and to ID 0
    bus.close()
    sim.close()


def test_backup_and_restore(tmp_path) -> None:  # type: ignore[no-untyped-def]
    sim, bus = sim_bus([1, 2])
    motors = [bus.motor(1).procedures, bus.motor(2).procedures]
    bus.motor(2).set("position-kp", 77)
    document = bus.run(cfg.backup(motors))
    cfg.save_backup(document, tmp_path / "b.json")
    bus.motor(2).set("position-kp", 5)
    bus.motor(1).set("ratio", 3)
    changed = bus.run(cfg.restore(motors, cfg.load_backup(tmp_path / "b.json")))
    assert len(changed) == 2
    assert bus.motor(2).get("position-kp") == 77 and bus.motor(1).get("ratio") == 1.0
    with pytest.raises(ValueError, match="not a nurimc backup"):
        bus.run(cfg.restore(motors, {"format": "x"}))
    bus.close()
    sim.close()


def test_recover_runaway_flips_direction(one) -> None:  # type: ignore[no-untyped-def]
    motor = one.motor(1)
    assert one.run(cfg.recover_runaway(motor.procedures)) == "cw"
    assert motor.get("direction") == "cw" and motor.get("control") == "off"


def test_faults_never_yield_a_wrong_value() -> None:
    faults = FaultConfig(drop_rate=0.02, flip_rate=0.02, noise_rate=0.02, echo=True)
    sim, bus = sim_bus([1], faults=faults, seed=7, retries=1)
    bus.core.late_answer = 0.01  # no delay faults here: a short quiet period after each failure suffices
    bus.motor(1).procedures  # noqa: B018
    expected = None
    good = failed = 0
    for _ in range(200):
        try:
            answer = bus.request(RequestPosition(1))
        except (NoAnswer, CorruptedAnswer):
            failed += 1
            continue
        assert isinstance(answer, PositionFeedback)
        expected = expected or answer
        assert answer == expected  # the motor is still: every value returned is the true one
        good += 1
    assert good > 100 and bus.stats.echo_frames > 0 and bus.stats.dropped_bytes > 0
    bus.close()
    sim.close()


def test_threads_share_one_bus(one) -> None:  # type: ignore[no-untyped-def]
    errors: list[BaseException] = []

    def worker() -> None:
        try:
            for _ in range(20):
                assert one.motor(1).get("ratio") == 1.0
        except BaseException as err:
            errors.append(err)

    threads = [threading.Thread(target=worker) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_traffic_log_replays(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from nurimc import Bus
    from nurimc.sim import SimBus
    from nurimc.transport import SerialTransport

    sim = SimBus()
    sim.add_controller(id=1)
    bus = Bus(SerialTransport(sim.open_serial(), "sim://"), log_path=str(tmp_path / "t.log"))
    bus.motor(1).read_state()
    bus.close()
    entries = list(replay(tmp_path / "t.log"))
    assert [(e["dir"], e["message"].name) for e in entries] == [("tx", "request_position"), ("rx", "position_feedback")]
    assert json.loads((tmp_path / "t.log").read_text().splitlines()[0])["dir"] == "tx"
    sim.close()


def test_settings_not_applied_is_reported() -> None:
    from nurimc import Bus
    from nurimc.protocol import Ratio, SetRatio, decode

    from .fakes import ScriptedTransport

    def stubborn(data: bytes) -> bytes:  # a controller that ignores settings writes
        message = decode(data[: data[3] + 4])
        return b"" if isinstance(message, SetRatio) else Ratio(1, 10).encode()

    bus = Bus(ScriptedTransport(stubborn))
    with pytest.raises(SettingNotApplied, match="did not take"):
        bus.motor(1).set("ratio", 2)
