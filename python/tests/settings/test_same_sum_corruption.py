"""No silent change from a corrupted read (issue 21): answers corrupted so that their checksum
still holds are injected at random; a settings write changes the setting asked for, or the user
gets an error, and no other setting of the controller ever changes."""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nurimc import NurimcError
from nurimc.procedures import config
from nurimc.procedures.settings import SETTINGS
from nurimc.sim import FaultConfig, SimBus
from nurimc.sim.faults import FaultInjector

from ..client.simfixtures import sim_bus

WRITABLE = sorted(name for name, s in SETTINGS.items() if s.command is not None and name != "control")
GAINS = sorted(name for name in WRITABLE if SETTINGS[name].answer.endswith("_gains"))


def value_for(name: str, data: st.DataObject) -> int:
    """A wire value the controller accepts for the setting."""
    spec = SETTINGS[name].spec
    high = min(spec.max, 50) if name.endswith("rated-current") else spec.max  # both products accept 0.1..5 A
    return data.draw(st.integers(max(spec.min, 1) if name.endswith("rated-current") else spec.min, high))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(WRITABLE + GAINS * 2),  # the read-modify-write settings twice as often
    rate=st.sampled_from([0.2, 0.4, 0.6]),
    seed=st.integers(0, 2**32 - 1),
    data=st.data(),
)
def test_only_the_setting_asked_for_changes(name: str, rate: float, seed: int, data: st.DataObject) -> None:
    sim, bus = sim_bus([1], faults=FaultConfig(same_sum_rate=rate), seed=seed)
    try:
        controller = sim.controllers[0]
        field = name.replace("-", "_")
        before = controller.settings.to_dict()
        raw = value_for(name, data)
        s = SETTINGS[name]
        try:
            bus.motor(1).set(name, s.to_physical(raw))
            succeeded = True
        except NurimcError:
            succeeded = False
        after = controller.settings.to_dict()
    finally:
        bus.close()
        sim.close()
    changed = {k for k in before if before[k] != after[k]}
    assert changed <= {field}, f"{name} = {raw}: also changed {changed - {field}}: {before} -> {after}"
    if succeeded:
        assert after[field] == raw, f"{name}: reported success but the controller holds {after[field]}"
    else:
        assert after[field] in (before[field], raw)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rate=st.sampled_from([0.2, 0.4]), seed=st.integers(0, 2**32 - 1), data=st.data())
def test_restore_under_corruption_writes_only_the_backups_values(rate: float, seed: int, data: st.DataObject) -> None:
    """Every setting ends at its old value or the backup's; after a success, at the backup's."""
    sim, bus = sim_bus([1], seed=seed)
    try:
        motor = bus.motor(1)
        document = bus.run(config.backup([motor.procedures]))
        saved = controller_fields(sim)
        for name in data.draw(st.lists(st.sampled_from(WRITABLE), min_size=1, max_size=4, unique=True)):
            field = name.replace("-", "_")
            setattr(sim.controllers[0].settings, field, value_for(name, data))
        before = controller_fields(sim)
        sim.faults = FaultInjector(FaultConfig(same_sum_rate=rate), seed)
        try:
            bus.run(config.restore([motor.procedures], document))
            succeeded = True
        except NurimcError:
            succeeded = False
        after = controller_fields(sim)
    finally:
        bus.close()
        sim.close()
    for field, value in after.items():
        assert value in (before[field], saved[field]), f"{field}: {before[field]} -> {value} (backup {saved[field]})"
    if succeeded:
        assert after == saved


def controller_fields(sim: SimBus) -> dict[str, int]:
    fields = sim.controllers[0].settings.to_dict()
    return {k: v for k, v in fields.items() if k not in ("id", "baud_index", "control")}
