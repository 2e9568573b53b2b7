"""The bridge's parameters and services (services.py, parameters.py): each handler called with
request objects, on the in-process simulator, with the bridge node built as the other tests build it.

Most run on virtual time (the bus service stepped by the handler's own job); the estop and the
outage need the node's and the service's threads, on real time (bounds generous, waits on conditions).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from nurimc.drivers.sync import Bus
from nurimc.ros2 import diffdrive
from nurimc.ros2 import interfaces as i
from nurimc.ros2.bridge import Bridge
from nurimc.ros2.dds import Participant
from nurimc.ros2.node import BridgeNode
from nurimc.ros2.parameters import from_value, port_lost, to_value
from nurimc.ros2.services import ServiceSpec, bridge_services
from nurimc.service import BusService
from nurimc.sim import SimBus

from ..client.simfixtures import REAL_CLOCK, sim_bus
from ..transport.outage import BAUD, cuttable_bus

EXPECTED = [
    ("/svc/nurimc/list_parameters", "rcl_interfaces/srv/ListParameters"),
    ("/svc/nurimc/get_parameters", "rcl_interfaces/srv/GetParameters"),
    ("/svc/nurimc/set_parameters", "rcl_interfaces/srv/SetParameters"),
    ("/svc/nurimc/set_parameters_atomically", "rcl_interfaces/srv/SetParametersAtomically"),
    ("/svc/nurimc/describe_parameters", "rcl_interfaces/srv/DescribeParameters"),
    ("/svc/nurimc/get_parameter_types", "rcl_interfaces/srv/GetParameterTypes"),
    ("/svc/nurimc/read_setting", "nurimc_msgs/srv/ReadSetting"),
    ("/svc/nurimc/write_setting", "nurimc_msgs/srv/WriteSetting"),
    ("/svc/nurimc/reset_position", "nurimc_msgs/srv/ResetPosition"),
    ("/svc/nurimc/estop", "std_srvs/srv/Trigger"),
]


class Services:
    """The handlers by short name: `services.call("get_parameters", request)`."""

    def __init__(self, specs: list[ServiceSpec]) -> None:
        self.specs = {spec.name.rsplit("/", 1)[1]: spec for spec in specs}

    def call(self, name: str, request: Any) -> Any:
        spec = self.specs[name]
        assert isinstance(request, spec.request), (name, type(request))
        response = spec.handler(request)
        assert isinstance(response, spec.response), (name, type(response))
        return response

    def get(self, *names: str) -> list[Any]:
        response = self.call("get_parameters", i.GetParameters_Request(list(names)))
        return [from_value(v) for v in response.values]

    def set(self, **values: Any) -> list[i.SetParametersResult]:
        parameters = [i.Parameter(name.replace("__", "."), to_value(v)) for name, v in values.items()]
        return list(self.call("set_parameters", i.SetParameters_Request(parameters)).results)


@contextmanager
def virtual_node(ids: tuple[int, ...] = (1, 2)) -> Iterator[tuple[SimBus, BridgeNode, Services, list[str]]]:
    """A bridge node on a VirtualClock: its service has no thread, each handler's job steps it."""
    sim, bus = sim_bus(list(ids), baud=115200)
    service = BusService(bus, program="nurimc ros2")
    lines: list[str] = []
    node = BridgeNode(
        bus, Bridge(list(ids), [f"joint{n}" for n in ids]), Participant(), "/svc", rate=50, log=lines.append,
        node_name=None, service=service,
    )  # fmt: skip
    try:
        node.subscribe()
        service.run_for(0.2)
        yield sim, node, Services(bridge_services(node, "nurimc", "/svc")), lines
    finally:
        node.close()
        service.close()
        bus.close()
        sim.close()


def wait_for(condition: Callable[[], bool], what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.01)


# -- the list the transport serves -----------------------------------------------------------


def test_bridge_services_lists_every_service_with_its_types() -> None:
    with virtual_node() as (_, node, _services, _):
        specs = bridge_services(node, "nurimc", "/svc")
        assert [(s.name, s.srv_type) for s in specs] == EXPECTED
        for spec in specs:
            package, _, name = spec.srv_type.split("/")
            assert spec.request.__idl_typename__ == f"{package}::srv::dds_::{name}_Request_"
            assert spec.response.__idl_typename__ == f"{package}::srv::dds_::{name}_Response_"
        assert bridge_services(node, "arm_bridge", "/")[0].name == "/arm_bridge/list_parameters"


# -- parameters ---------------------------------------------------------------------------------


def test_list_parameters_as_ros2_param_list_asks() -> None:
    with virtual_node() as (_, _, services, _):
        every = services.call("list_parameters", i.ListParameters_Request([], 0)).result
        for name in ("rate", "command_timeout", "move_velocity", "ramp", "ids", "joint_names", "frame_id"):
            assert name in every.names
        assert "motor_1.position_kp" in every.names and "motor_2.direction" in every.names
        assert "motor_1.firmware" in every.names  # read-only, listed
        assert set(every.prefixes) == {"motor_1", "motor_2"}
        top = services.call("list_parameters", i.ListParameters_Request([], 1)).result
        assert "rate" in top.names and not any("." in name for name in top.names)
        one = services.call("list_parameters", i.ListParameters_Request(["motor_2"], 0)).result
        assert one.names and all(name.startswith("motor_2.") for name in one.names)
        assert one.prefixes == ["motor_2"]


def test_get_parameters_reads_the_bridge_and_freshly_the_controller() -> None:
    with virtual_node() as (sim, node, services, lines):
        rate, ids, names, unknown = services.get("rate", "ids", "joint_names", "no_such")
        assert (rate, ids, names, unknown) == (50.0, [1, 2], ["joint1", "joint2"], None)
        with sim.lock:
            sim.controller(1).settings.position_kp = 91
            sim.controller(2).settings.ratio = 125
            sim.controller(2).settings.direction = 1
        reads = node.service.me.requests
        kp, ratio, direction = services.get("motor_1.position_kp", "motor_2.ratio", "motor_2.direction")
        assert (kp, ratio, direction) == (91, 12.5, "cw")  # fresh: the controller's values now
        assert node.service.me.requests == reads + 2  # one job per motor
        asked = ["rate", "ids", "motor_1.position_kp", "motor_1.direction", "x"]
        types = services.call("get_parameter_types", i.GetParameterTypes_Request(asked)).types
        assert list(types) == [
            i.PARAMETER_DOUBLE, i.PARAMETER_INTEGER_ARRAY, i.PARAMETER_INTEGER, i.PARAMETER_STRING, i.PARAMETER_NOT_SET,
        ]  # fmt: skip
        sim.controllers.remove(gone := sim.controller(2))
        sim._forget_index()
        value = services.call("get_parameters", i.GetParameters_Request(["motor_2.ratio", "rate"])).values
        assert value[0].type == i.PARAMETER_NOT_SET and value[1].double_value == 50.0  # no answer: not set
        assert any("get_parameters: ID 2" in line and "value not set" in line for line in lines), lines
        sim.controllers.append(gone)
        sim._forget_index()


def test_describe_parameters_gives_ranges_and_read_only() -> None:
    with virtual_node() as (_, _, services, _):
        names = ["rate", "ids", "joint_names", "motor_1.position_kp", "motor_1.ratio", "motor_1.direction"]
        d = services.call("describe_parameters", i.DescribeParameters_Request([*names, "motor_1.firmware", "x"]))
        rate, ids, joints, kp, ratio, direction, firmware, unknown = d.descriptors
        assert rate.type == i.PARAMETER_DOUBLE and not rate.read_only and rate.description
        assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (0, 10_000)
        assert ids.read_only and "--ids" in ids.additional_constraints
        assert joints.read_only and "--joint-names" in joints.additional_constraints
        assert (kp.integer_range[0].from_value, kp.integer_range[0].to_value) == (1, 254) and not kp.read_only
        assert ratio.floating_point_range[0].to_value == pytest.approx(6553.3)
        assert direction.type == i.PARAMETER_STRING and "ccw, cw" in direction.additional_constraints
        assert firmware.read_only
        assert unknown.type == i.PARAMETER_NOT_SET and unknown.description == "no such parameter"


def test_a_rate_change_subscribes_the_poll_again_and_reads_back() -> None:
    with virtual_node() as (_, node, services, _):
        (result,) = services.set(rate=20.0)
        assert result.successful and "rate = 20.0" in result.reason, result.reason
        assert node.rate == 20.0 and node.period == pytest.approx(0.05)
        assert node.subscription is not None and node.subscription.rate_hz == 20.0
        assert node.service.poll_rates == {1: 20.0, 2: 20.0}
        node._take_round()
        before = node.subscription.delivered
        node.service.run_for(1.0)
        assert 36 <= node.subscription.delivered - before <= 42  # 2 joints at 20/s, not 50/s
        assert services.get("rate") == [20.0]
        (integer,) = services.set(rate=30)  # an integer where a double is asked: widened
        assert integer.successful and node.rate == 30.0


def test_out_of_range_wrong_type_and_read_only_are_refused_with_the_reason_and_change_nothing() -> None:
    with virtual_node() as (_, node, services, _):
        (too_fast,) = services.set(rate=20_000.0)
        assert not too_fast.successful and "out of range 0..10000" in too_fast.reason
        (text,) = services.set(command_timeout="fast")
        assert not text.successful and "wrong type string; give a double" in text.reason
        (ids,) = services.set(ids=[3, 4])
        assert not ids.successful and "read-only" in ids.reason and "--ids" in ids.reason
        (names,) = services.set(joint_names=["a", "b"])
        assert not names.successful and "--joint-names" in names.reason
        (unknown,) = services.set(speed=1.0)
        assert not unknown.successful and "no such parameter" in unknown.reason
        assert (node.rate, node.bridge.command_timeout, list(node.bridge.ids)) == (50.0, 0.5, [1, 2])
        assert node.subscription is not None and node.subscription.rate_hz == 50.0


def test_set_parameters_gives_one_result_each_and_atomically_all_or_none() -> None:
    with virtual_node() as (_, node, services, _):
        results = services.set(rate=10.0, command_timeout=-1.0, ramp=0.5)
        assert [r.successful for r in results] == [True, False, True]
        assert "command_timeout: -1 is out of range 0..3600 s" in results[1].reason
        assert (node.rate, node.bridge.command_timeout, node.bridge.ramp) == (10.0, 0.5, 0.5)
        atomic = i.SetParametersAtomically_Request(
            [i.Parameter("rate", to_value(25.0)), i.Parameter("move_velocity", to_value(10_000.0))]
        )
        result = services.call("set_parameters_atomically", atomic).result
        assert not result.successful and "move_velocity" in result.reason
        assert node.rate == 10.0 and node.bridge.move_velocity == pytest.approx(6.2832, abs=1e-3)  # none applied
        good = i.SetParametersAtomically_Request(
            [i.Parameter("rate", to_value(25.0)), i.Parameter("command_timeout", to_value(2.0))]
        )
        assert services.call("set_parameters_atomically", good).result.successful
        assert (node.rate, node.bridge.command_timeout) == (25.0, 2.0)
        two = i.SetParametersAtomically_Request(
            [i.Parameter("motor_1.position_kp", to_value(50)), i.Parameter("motor_2.position_kp", to_value(50))]
        )
        refused = services.call("set_parameters_atomically", two).result
        assert not refused.successful and "one at a time" in refused.reason


def test_a_controller_setting_parameter_is_written_and_read_back_on_the_controller() -> None:
    with virtual_node() as (sim, _, services, _):
        (kp,) = services.set(motor_1__position_kp=77)
        assert kp.successful and "motor_1.position_kp = 77 (read back)" in kp.reason, kp.reason
        assert sim.controller(1).settings.position_kp == 77
        assert services.get("motor_1.position_kp") == [77]
        (ratio,) = services.set(motor_2__ratio=12.5)
        assert ratio.successful and sim.controller(2).settings.ratio == 125
        (direction,) = services.set(motor_1__direction="cw")
        assert direction.successful and sim.controller(1).settings.direction == 1
        before = sim.controller(1).settings.position_kp
        (high,) = services.set(motor_1__position_kp=300)
        assert not high.successful and "out of range 1..254" in high.reason
        (fraction,) = services.set(motor_1__position_kp=7.5)
        assert not fraction.successful and "wrong type double; give an integer" in fraction.reason
        (wrong,) = services.set(motor_1__direction=1)
        assert not wrong.successful and "give a string: ccw or cw" in wrong.reason
        (firmware,) = services.set(motor_1__firmware=3)
        assert not firmware.successful and "read-only" in firmware.reason
        assert sim.controller(1).settings.position_kp == before


def test_the_mobile_bases_limits_are_parameters_checked_together() -> None:
    with virtual_node() as (_, node, services, _):
        base = diffdrive.attach(node, diffdrive.BaseConfig(1, 2, 0.05, 0.3))  # after bridge_services: seen too
        listed = services.call("list_parameters", i.ListParameters_Request(["base"], 0)).result
        assert "base.max_linear" in listed.names and "base.wheel_radius" in listed.names
        (slower,) = services.set(base__max_linear=0.5)
        assert slower.successful and base.config.max_linear == 0.5
        assert services.get("base.max_linear", "base.left_id") == [0.5, 1]
        (too_much,) = services.set(base__max_linear=40.0)  # within --max-linear's range, beyond the wheels'
        assert not too_much.successful and "more than the controller's" in too_much.reason, too_much.reason
        (radius,) = services.set(base__wheel_radius=0.1)
        assert not radius.successful and "--wheel-radius" in radius.reason
        assert (base.config.max_linear, base.config.wheel_radius) == (0.5, 0.05)
        (stop_after,) = services.set(base__timeout=1.5)
        assert stop_after.successful and base.config.timeout == 1.5


def test_a_handler_that_breaks_answers_with_the_error_in_its_own_fields(monkeypatch: pytest.MonkeyPatch) -> None:
    with virtual_node() as (_, node, services, lines):

        def broken(*_: Any) -> Any:
            raise RuntimeError("bug")

        monkeypatch.setattr(node.motors[1].procedures, "set", broken)
        monkeypatch.setattr(node.motors[1].procedures, "setting_from", broken)
        wrote = services.call("write_setting", i.WriteSetting_Request(1, "ratio", "10"))
        assert not wrote.success and "bug" in wrote.message
        for spec in bridge_services(node, "nurimc", "/svc"):  # every handler, given a request it cannot take
            answer = spec.handler(None)
            assert isinstance(answer, spec.response), spec.name
        got = services.specs["get_parameters"]
        assert got.handler(i.GetParameters_Request(["motor_1.ratio"])).values[0].type == i.PARAMETER_NOT_SET
        assert any("internal error in the bridge" in line for line in lines), lines


# -- nurimc_msgs services --------------------------------------------------------------------


def test_read_and_write_setting_with_read_back() -> None:
    with virtual_node() as (sim, _, services, _):
        read = services.call("read_setting", i.ReadSetting_Request(2, "response-time"))
        assert read.success and read.value == str(sim.controller(2).settings.response_time * 100)
        wrote = services.call("write_setting", i.WriteSetting_Request(1, "ratio", "12.5"))
        assert wrote.success and wrote.value_read_back == "12.5", wrote.message
        assert sim.controller(1).settings.ratio == 125
        assert services.call("read_setting", i.ReadSetting_Request(1, "ratio")).value == "12.5"
        gain = services.call("write_setting", i.WriteSetting_Request(1, "speed_kp", "33"))
        assert gain.success and sim.controller(1).settings.speed_kp == 33
        for request, said in [
            (i.WriteSetting_Request(1, "position-kp", "999"), "out of range"),
            (i.WriteSetting_Request(9, "ratio", "10"), "ID 9 is not one of the bridge's motors (1, 2)"),
            (i.WriteSetting_Request(1, "id", "5"), "restart it with --ids"),
            (i.WriteSetting_Request(1, "gain", "5"), "unknown setting 'gain'"),
            (i.WriteSetting_Request(1, "firmware", "5"), "read-only"),
            (i.WriteSetting_Request(1, "ratio", ""), "give a value"),
        ]:
            answer = services.call("write_setting", request)
            assert not answer.success and said in answer.message, (request, answer.message)
            assert answer.value_read_back == ""
        assert sim.controller(1).settings.ratio == 125 and sim.controller(1).settings.position_kp != 999
        unknown = services.call("read_setting", i.ReadSetting_Request(1, "speed"))
        assert not unknown.success and "unknown setting" in unknown.message


def test_a_write_that_does_not_take_is_refused_with_what_was_read(monkeypatch: pytest.MonkeyPatch) -> None:
    with virtual_node() as (sim, _, services, _):
        controller = sim.controller(1)
        before = controller.settings.rated_speed
        original = controller.handle

        def deaf_to_rated_speed(msg: Any, *args: Any, **kwargs: Any) -> Any:
            if getattr(msg, "name", "") == "set_rated_speed":
                return None  # the write is lost: the read-back shows the old value
            return original(msg, *args, **kwargs)

        monkeypatch.setattr(controller, "handle", deaf_to_rated_speed)
        answer = services.call("write_setting", i.WriteSetting_Request(1, "rated-speed", str(before + 100)))
        assert not answer.success and "did not take" in answer.message, answer.message
        assert controller.settings.rated_speed == before


def test_reset_position_makes_every_motor_read_zero() -> None:
    with virtual_node() as (sim, node, services, _):
        for controller in sim.controllers:
            with sim.lock:
                controller.servo.motor.angle += 400.0
                controller.servo.hold()
        readings = node.service.run(lambda bus: [node.motors[n].read_state() for n in (1, 2)])
        assert all(abs(r.device_position) > 10 for r in readings)
        answer = services.call("reset_position", i.ResetPosition_Request(0))
        assert answer.success and answer.message == "ID 1: 0° (read back); ID 2: 0° (read back)", answer.message
        readings = node.service.run(lambda bus: [node.motors[n].read_state() for n in (1, 2)])
        assert all(abs(r.device_position) < 1.0 and abs(r.position) < 1.0 for r in readings)
        assert all(j.state is not None and abs(j.state.position) < 1.0 for j in node.bridge.joints)  # at once
        one = services.call("reset_position", i.ResetPosition_Request(2))
        assert one.success and one.message.startswith("ID 2: 0°")
        other = services.call("reset_position", i.ResetPosition_Request(7))
        assert not other.success and "ID 7 is not one of the bridge's motors" in other.message


# -- on real time: the estop, and a port outage ---------------------------------------------------


@pytest.mark.realtime
def test_a_running_node_takes_a_rate_and_its_estop_service_stops_every_motor_with_read_back() -> None:
    sim, bus = sim_bus([1, 2], baud=115200, clock=REAL_CLOCK)
    lines: list[str] = []
    node = BridgeNode(
        bus, Bridge([1, 2], ["a", "b"]), Participant(), "/svcstop", rate=20, log=lines.append, node_name=None
    )
    services = Services(bridge_services(node, "nurimc", "/svcstop"))
    try:
        node.prepare(0)
        answer = services.call("estop", i.Trigger_Request())
        assert not answer.success and "not running" in answer.message
        node.start()
        wait_for(lambda: node.published >= 3, "readings")
        rate, timeout = services.set(rate=10.0, command_timeout=0.0)  # made on the running node's thread
        assert rate.successful and timeout.successful and "rate = 10.0" in rate.reason, rate.reason
        assert node.subscription is not None and node.subscription.rate_hz == 10.0
        node._push("velocity", [1.0, 1.0])
        wait_for(lambda: all(j.mode == "velocity" for j in node.bridge.joints), "both turning")
        wait_for(lambda: all(sim.controller(n).settings.control == 0 for n in (1, 2)), "control on")
        answer = services.call("estop", i.Trigger_Request())
        assert answer.success, answer.message
        assert "ID 1: control off (read back); ID 2: control off (read back)" in answer.message
        assert "publish false on estop" in answer.message
        assert all(sim.controller(n).settings.control == 1 for n in (1, 2))  # control off on the controllers
        assert node.bridge.estop_latched and node.service.latched == {1, 2}
    finally:
        node.close()
        bus.close()
        sim.close()


@pytest.mark.realtime
def test_during_an_outage_every_service_answers_at_once_with_the_outage(tmp_path: Path) -> None:
    with cuttable_bus("tcp", tmp_path, ids=(1, 2)) as (sim, proxy):
        bus = Bus.open(proxy.url, BAUD, reconnect=True)
        lines: list[str] = []
        node = BridgeNode(
            bus, Bridge([1, 2], ["a", "b"]), Participant(), "/svcout", rate=20, log=lines.append, node_name=None
        )
        services = Services(bridge_services(node, "nurimc", "/svcout"))
        try:
            node.prepare(0)
            node.start()
            wait_for(lambda: node.published >= 3, "readings before the cut")
            proxy.cut()
            wait_for(lambda: port_lost(node) is not None, "the bridge sees the port lost")
            calls: list[tuple[str, Any, Callable[[Any], tuple[bool, str]]]] = [
                ("read_setting", i.ReadSetting_Request(1, "ratio"), lambda r: (r.success, r.message)),
                ("write_setting", i.WriteSetting_Request(1, "ratio", "10"), lambda r: (r.success, r.message)),
                ("reset_position", i.ResetPosition_Request(0), lambda r: (r.success, r.message)),
                ("estop", i.Trigger_Request(), lambda r: (r.success, r.message)),
                (
                    "set_parameters",
                    i.SetParameters_Request([i.Parameter("motor_1.position_kp", to_value(40))]),
                    lambda r: (r.results[0].successful, r.results[0].reason),
                ),
            ]
            for name, request, said in calls:
                began = time.monotonic()
                success, message = said(services.call(name, request))
                assert time.monotonic() - began < 1.0, f"{name} took {time.monotonic() - began:.2f} s"
                assert not success and "is lost" in message, (name, message)
            got = services.call("get_parameters", i.GetParameters_Request(["motor_1.ratio", "rate"]))
            assert got.values[0].type == i.PARAMETER_NOT_SET and got.values[1].double_value == 20.0
            wait_for(lambda: node.bridge.estop_latched, "the estop asked during the outage is latched")
            proxy.restore()
            wait_for(lambda: port_lost(node) is None, "the port back")
            wait_for(lambda: all(sim.controller(n).settings.control == 1 for n in (1, 2)), "control off on the return")
            read = i.ReadSetting_Request(1, "ratio")
            wait_for(lambda: services.call("read_setting", read).success, "a read once it is back")
        finally:
            node.close()
            bus.close()
