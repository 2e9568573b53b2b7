"""The asyncio bus on the simulator: the same procedures as the sync bus, awaited."""

from __future__ import annotations

import asyncio

from nurimc import AsyncBus
from nurimc.procedures.group import read_states
from nurimc.transport import SerialTransport

from .simfixtures import virtual_sim


def test_async_motion_settings_and_concurrency() -> None:
    sim = virtual_sim(eeprom_time=0.02)
    clock = sim.virtual
    assert clock is not None
    for device_id in (1, 2):
        sim.add_controller(id=device_id)

    async def main() -> None:
        bus = AsyncBus(SerialTransport(sim.open_serial(), "sim://", latency=0.002), clock=clock)
        one, two = bus.motor(1), bus.motor(2)
        assert await one.set("resolution", 1000) == 1000
        assert await one.set("ratio", "2.5") == 2.5
        await one.move_to(60, rpm=300)
        # two tasks share the bus; the lock keeps their transactions apart
        ratios = await asyncio.gather(*(two.get("ratio") for _ in range(10)), one.get("ratio"))
        assert ratios == [1.0] * 10 + [2.5]
        for _ in range(100):
            if abs((await one.read_state()).position - 60) < 0.5:
                break
            await clock.sleep_async(0.02)
        assert abs((await one.read_state()).position - 60) < 0.5
        states = await bus.run(read_states([one.procedures, two.procedures]))
        assert set(states) == {1, 2}
        await bus.close()

    asyncio.run(main())
    sim.close()
