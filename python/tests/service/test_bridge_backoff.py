"""The ROS 2 bridge's readings back off a motor that stops answering (issue 36): virtual time."""

from __future__ import annotations

from nurimc.procedures.motor import Motor, MotorState
from nurimc.ros2.node import BridgeNode
from nurimc.service.backoff import Backoff

from ..client.simfixtures import sim_bus


def test_a_silent_motor_is_read_less_often_and_the_others_keep_their_rate() -> None:
    sim, bus = sim_bus([1, 2, 3], baud=115200)
    said: list[str] = []
    node = BridgeNode.__new__(BridgeNode)  # the read step alone: no DDS participant needed
    node.bus, node.slot, node.silent, node._log = bus, None, Backoff(), said.append
    node.motors = {i: Motor(bus, i) for i in (1, 2, 3)}

    def rounds(seconds: float) -> tuple[int, dict[int, int]]:
        n, good = 0, {1: 0, 2: 0, 3: 0}
        end = bus.clock.now() + seconds
        while bus.clock.now() < end:
            for device_id, result in node.read_states().items():
                good[device_id] += isinstance(result, MotorState)
            n += 1
            bus.clock.sleep(0.02)
        return n, good

    alone, _ = rounds(1.0)
    gone = sim.controller(3)
    with sim.lock:
        sim.controllers.remove(gone)
        sim._forget_index()
    rounds(1.5)  # it is found silent and backed off
    silent, good = rounds(3.0)
    assert silent / 3.0 >= 0.8 * alone, (alone, silent)
    assert any("ID 3: no answer" in line for line in said)
    with sim.lock:
        sim.controllers.append(gone)
        sim._forget_index()
    _, good = rounds(2.0)
    assert good[3] >= 20 and any("ID 3 answers again" in line for line in said)
    bus.close()
    sim.close()
