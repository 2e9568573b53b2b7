"""Property: under any mix of wire faults, a read returns the value the controller produced
for that very call's request, or raises a typed error (a NurimcError). Never an old value.

Every fault the stale-answer rule must survive (docs/protocol.md, "Stale answers"): lost
answers, late answers (a late answer holds back the controller's later ones: it answers in
order), duplicated answers (back to back), corrupted bytes (drops, flips, noise) and an
echoing adapter; for single reads, sequential group reads and broadcast group reads, on a
wire-timed bus on virtual time (so a run is exact and quick, loaded host or not).

The motors turn at constant speeds, so every position one reports is tied to the moment it
was asked: a value must lie between the true positions just before and just after its call.
A value the controller never sent (noise that an 8-bit checksum lets through, about one
corrupted frame in 256) is not a stale one: it is told apart by the simulator's record of what
each controller sent, and must stay that rare. Answer delays stay within the documented bound
(deadline + late_answer).
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurimc import Group, NurimcError
from nurimc.procedures.group import stagger_slot
from nurimc.procedures.motor import MotorState
from nurimc.protocol import PositionFeedback, decode
from nurimc.sim import FaultConfig, SimBus
from nurimc.sim.controller import Reply, SimController

from .simfixtures import sim_bus

faults = st.builds(
    FaultConfig,
    drop_rate=st.sampled_from([0.0, 0.005, 0.02]),
    flip_rate=st.sampled_from([0.0, 0.002]),
    noise_rate=st.sampled_from([0.0, 0.01, 0.03]),
    delay_ms=st.sampled_from([0.0, 20.0, 60.0, 80.0]),
    delay_rate=st.sampled_from([0.1, 0.3, 0.7]),
    miss_rate=st.sampled_from([0.0, 0.03, 0.1, 0.3]),
    dup_rate=st.sampled_from([0.0, 0.05, 0.3]),
    echo=st.booleans(),
)
SPEEDS = {1: 10.0, 2: -20.0, 3: 30.0}  # RPM: every motor turning, each its own way


def true_angle(sim: SimBus, controller: SimController) -> float:
    with sim.lock:
        controller.advance_to(sim.now())
        return controller.logical_angle()


@settings(max_examples=80, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(
    config=faults,
    seed=st.integers(0, 1000),
    retries=st.integers(0, 2),
    rate=st.sampled_from([115200, 1_000_000]),
    read=st.sampled_from(["single", "group", "broadcast"]),
)
def test_a_read_is_fresh_or_a_typed_error(config: FaultConfig, seed: int, retries: int, rate: int, read: str) -> None:
    sim, bus = sim_bus(list(SPEEDS), baud=rate, faults=config, seed=seed, wire_timing=True, retries=retries)
    controllers = {c.id: c for c in sim.controllers}
    slot = stagger_slot(rate)
    for k, controller in enumerate(controllers.values()):
        controller.settings.resolution = 1000  # 0.09 deg steps
        controller.settings.response_time = (k + 1) * slot  # staggered for the broadcast read
        controller.apply_settings()
    group = Group(bus, list(SPEEDS))
    group.slot = slot
    sent: set[tuple[int, int, int, int]] = set()  # what the controllers really sent
    send = sim._send

    def record(reply: Reply) -> None:
        answer = decode(reply.frame)
        if isinstance(answer, PositionFeedback):
            sent.add((answer.id, answer.position, answer.speed, answer.current))
        send(reply)

    sim._send = record  # type: ignore[method-assign]
    forged = values = 0
    try:
        bus.send(*(m.make_run(SPEEDS[m.id]) for m in group.motors))
        for _ in range(12):
            before = {i: true_angle(sim, c) for i, c in controllers.items()}
            if read == "single":
                try:
                    states: dict[int, MotorState | Exception] = {1: bus.motor(1).read_state()}
                except NurimcError:
                    continue
            else:
                states = group.read_states() if read == "group" else group.read_states_broadcast()
                assert list(states) == list(SPEEDS)  # always whole
            after = {i: true_angle(sim, c) for i, c in controllers.items()}
            for device_id, state in states.items():
                if isinstance(state, Exception):
                    assert isinstance(state, NurimcError)
                    continue
                values += 1
                wire = (
                    device_id,
                    round(abs(state.device_position) * 100),
                    round(abs(state.speed) * 10),  # the wire carries the magnitude; the sign is the trend
                    round(state.current * 10),
                )
                if wire not in sent:
                    forged += 1  # corrupted bytes with a matching checksum: not an old value
                    continue
                low, high = sorted((before[device_id], after[device_id]))
                assert low - 0.1 <= state.device_position <= high + 0.1, (device_id, before, state, after)
        assert forged <= max(1, values // 50), (forged, values)
    finally:
        bus.close()
        sim.close()
