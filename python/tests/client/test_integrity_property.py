"""Property: under any mix of wire faults, a read returns the value the controller produced
for that very call's request, or raises a typed error (a NurimcError). Never an old value.

The motor turns at a constant speed, so every position it reports is tied to the moment it
was asked: a value must lie between the true positions just before and just after its call.
Answer delays stay within the documented bound (deadline + late_answer, docs/protocol.md);
bit flips stay rare enough that two in one frame (which an 8-bit checksum can miss) do not
happen in a run.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurimc import Bus, NurimcError
from nurimc.sim import FaultConfig, SimBus
from nurimc.transport import SerialTransport

faults = st.builds(
    FaultConfig,
    drop_rate=st.sampled_from([0.0, 0.005, 0.02]),
    flip_rate=st.sampled_from([0.0, 0.002]),
    noise_rate=st.sampled_from([0.0, 0.01, 0.03]),
    delay_ms=st.sampled_from([0.0, 20.0, 45.0, 80.0]),
    delay_rate=st.sampled_from([0.1, 0.3, 0.7]),
    miss_rate=st.sampled_from([0.0, 0.05, 0.2]),
    echo=st.booleans(),
)


@settings(max_examples=8, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(config=faults, seed=st.integers(0, 1000), retries=st.integers(0, 2))
def test_a_read_is_fresh_or_a_typed_error(config: FaultConfig, seed: int, retries: int) -> None:
    sim = SimBus(faults=config, seed=seed)
    controller = sim.add_controller(id=1, baud=115200)
    controller.settings.resolution = 1000
    controller.apply_settings()
    bus = Bus(SerialTransport(sim.open_serial(baudrate=115200), "sim://", latency=0.002), retries=retries)
    motor = bus.motor(1)
    try:
        bus.send(motor.make_run(10))
        for _ in range(10):
            with sim.lock:
                controller.advance_to(sim.now())
                before = controller.logical_angle()
            try:
                state = motor.read_state()
            except NurimcError:
                continue
            with sim.lock:
                controller.advance_to(sim.now())
                after = controller.logical_angle()
            assert before - 0.1 <= state.device_position <= after + 0.1, (before, state.device_position, after)
    finally:
        bus.close()
        sim.close()
