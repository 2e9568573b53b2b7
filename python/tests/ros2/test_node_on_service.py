"""The bridge is a client of one bus service (issue 32): readings by subscription, commands as
jobs, its estop the service's. In process, on the simulator; waits for conditions, no fixed sleeps."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest

from nurimc.procedures.motor import MotorState
from nurimc.ros2.bridge import Bridge
from nurimc.ros2.dds import Participant
from nurimc.ros2.node import BridgeNode
from nurimc.service import BusService

from ..client.simfixtures import REAL_CLOCK, sim_bus


def wait_for(condition: Callable[[], bool], what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.01)


@pytest.mark.realtime  # the node's thread and the service's run on real time (bounds generous)
def test_readings_commands_and_estop_go_through_the_service() -> None:
    sim, bus = sim_bus([1, 2], baud=115200, clock=REAL_CLOCK)  # the node and the service run on real time
    service = BusService(bus, program="nurimc ros2")
    events: list[dict[str, object]] = []
    service.listen(events.append)
    lines: list[str] = []
    node = BridgeNode(
        bus, Bridge([1, 2], ["a", "b"]), Participant(), "/onservice", rate=20, log=lines.append,
        node_name=None, service=service,
    )  # fmt: skip
    try:
        assert node.service is service and not node.own_service
        assert service.motor(1) is node.motors[1]  # one handle per ID (the multi-turn tracker's history)
        node.prepare(0)
        node.start()
        assert service.poll_rates == {1: 20.0, 2: 20.0}  # the bridge subscribes at its --rate
        wait_for(lambda: node.published >= 10, "joint_states published from the service's polls")
        assert service.reads >= 2 * 9  # every reading is the service's
        requests = service.me.requests
        sent = dict(bus.core.commands_sent)
        node._push("position", [0.5, 0.5])
        wait_for(lambda: service.me.requests >= requests + 2, "both moves carried out as service jobs")
        wait_for(
            lambda: all(bus.core.commands_sent.get(i, 0) > sent.get(i, 0) for i in (1, 2)), "sent via BusCore.tell"
        )
        node._push("estop", True)
        wait_for(lambda: service.generation == 1, "the bridge's estop is the service's emergency stop")
        wait_for(lambda: any(e.get("type") == "estop" for e in events), "every program told")
        estop = next(e for e in events if e.get("type") == "estop")
        assert estop["from"] == "nurimc ros2" and estop["stopped"] == [1, 2]
        assert service.latched == {1, 2}
        assert any("control off confirmed on ID 1, 2" in line for line in lines), lines
        published = node.published
        wait_for(lambda: node.published >= published + 5, "readings go on after the stop")
    finally:
        node.close()
        service.close()
        bus.close()
        sim.close()


@pytest.mark.realtime
def test_a_node_without_a_service_makes_its_own_and_ends_it() -> None:
    sim, bus = sim_bus([3], baud=115200, clock=REAL_CLOCK)
    node = BridgeNode(bus, Bridge([3], ["c"]), Participant(), "/ownservice", rate=0, log=lambda _: None, node_name=None)
    try:
        assert node.own_service
        node.prepare(0)
        node.start()
        assert node.service.poll_rates[3] >= 1000  # --rate 0: as fast as the bus allows
        wait_for(lambda: node.published >= 20, "joint_states at --rate 0")
    finally:
        node.close()
        bus.close()
        sim.close()
    assert node.service._closed


def test_the_service_backs_off_a_silent_joint_and_the_node_says_so_on_virtual_time() -> None:
    sim, bus = sim_bus([1, 2, 3], baud=115200)  # a VirtualClock: the service is stepped here, no thread
    service = BusService(bus, program="nurimc ros2")
    lines: list[str] = []
    node = BridgeNode(
        bus, Bridge([1, 2, 3], ["a", "b", "c"]), Participant(), "/virtual", rate=50, log=lines.append,
        node_name=None, service=service,
    )  # fmt: skip
    try:
        node.subscribe()
        service.run_for(1.0)
        alone = node.subscription.delivered if node.subscription else 0
        assert 145 <= alone <= 153, alone  # 3 joints at 50/s
        rounds = node._take_round()
        assert all(isinstance(r, MotorState) for r in rounds.values())
        gone = sim.controller(3)
        with sim.lock:
            sim.controllers.remove(gone)
            sim._forget_index()
        service.run_for(1.0)  # found silent, backed off
        before = node.subscription.delivered if node.subscription else 0
        service.run_for(3.0)
        after = node.subscription.delivered if node.subscription else 0
        assert any("ID 3: no answer; read less often" in line for line in lines), lines
        assert after - before >= 0.8 * 2 * 50 * 3.0, after - before  # joints 1 and 2 keep their rate
        assert sum("no answer" in line for line in lines) == 1  # said once
        results = node._take_round()
        assert isinstance(results[3], Exception) and isinstance(results[1], MotorState)
        with sim.lock:
            sim.controllers.append(gone)
            sim._forget_index()
        service.run_for(2.0)
        assert any("ID 3 answers again" in line for line in lines), lines
        assert isinstance(node._take_round()[3], MotorState)
    finally:
        node.close()
        service.close()
        bus.close()
        sim.close()
