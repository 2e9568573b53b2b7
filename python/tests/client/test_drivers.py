"""The driver contract (docs/drivers.md), for the sync and the asyncio driver alike: an I/O
error, a timeout of the whole call or a cancellation is thrown into the procedure, which
restores the bus; a procedure is always closed when its driver is done with it.

The port here is a small fake bus: controllers that answer pings and firmware requests at
their own rate (bytes sent at another rate reach nobody), reads that wait like a real port.
"""

from __future__ import annotations

import asyncio
import inspect
import time
from collections.abc import Callable

import pytest

from nurimc import AsyncBus, Bus, NurimcError, PortError
from nurimc.core.actions import Procedure, Send, Wait
from nurimc.core.clock import REAL_CLOCK, SPIN, Clock, RealClock, VirtualClock
from nurimc.drivers.aio import drive_async
from nurimc.drivers.sync import drive
from nurimc.errors import CallTimeout
from nurimc.procedures.config import change_baud
from nurimc.procedures.discovery import Found, discover
from nurimc.protocol import BROADCAST_ID, Firmware, Ping, RequestFirmware, RequestPing, SetBaud, baud_index, decode

from .fakes import ScriptedTransport

RATES = [9600, 115200, 57600, 1_000_000]  # searched in the order 9600, 115200, 1000000, 57600
CONTROLLERS = {5: 115200, 9: 1_000_000}  # ID: rate
START_RATE = 19200


class FakeBus(ScriptedTransport):
    """Controllers behind a port; `fail_at`: the index of the write that raises PortError."""

    url = "fake://"

    def __init__(
        self, fail_at: int | None = None, controllers: dict[int, int] | None = None, clock: Clock | None = None
    ) -> None:
        super().__init__(self._answers)
        #: reads wait on this clock (virtual by default: a wait moves time, nothing sleeps)
        self.clock: Clock = VirtualClock() if clock is None else clock
        self.on_write: Callable[[int], object] | None = None  # called with each write's index
        self.controllers = dict(CONTROLLERS if controllers is None else controllers)
        self.fail_at = fail_at
        self.writes = 0
        self.rate = START_RATE
        self.rates_set: list[int] = []

    @property
    def baudrate(self) -> int:
        return self.rate

    @baudrate.setter
    def baudrate(self, rate: int) -> None:
        self.rate = rate
        self.rates_set.append(rate)

    def write(self, data: bytes) -> None:
        index, self.writes = self.writes, self.writes + 1
        if self.on_write is not None:
            self.on_write(index)
        if index == self.fail_at:
            raise PortError("the adapter was unplugged (write failed)")
        super().write(data)

    def _answers(self, data: bytes) -> bytes:
        request = decode(data) if data[2] != BROADCAST_ID else None
        out = b""
        for device_id, rate in sorted(self.controllers.items()):
            if rate != self.rate:
                continue
            if request is None or request == RequestPing(device_id):
                out += Ping(device_id).encode()
            elif request == RequestFirmware(device_id):
                out += Firmware(device_id, 40 + device_id).encode()
            elif isinstance(request, SetBaud) and request.id == device_id:
                self.controllers[device_id] = next(r for r in RATE_TABLE if baud_index(r) == request.baud_index)
        return out

    def read(self, max_bytes: int, timeout: float) -> bytes:
        if not self.inbox:
            self.clock.sleep(timeout)  # nothing comes: a real port waits its timeout out
            return b""
        return super().read(max_bytes, timeout)


RATE_TABLE = [9600, 19200, 57600, 115200, 1_000_000]
EXPECTED = [Found(5, 115200, 45), Found(9, 1_000_000, 49)]


def writes_of_a_whole_discovery() -> int:
    port = FakeBus()
    bus = Bus(port, clock=port.clock)
    assert bus.run(discover(bus.core, rates=RATES, lines=False)) == EXPECTED  # lines: tests/test_lines*
    assert port.rate == START_RATE
    return port.writes


@pytest.fixture(scope="module")
def write_count() -> int:
    count = writes_of_a_whole_discovery()
    assert count == len(RATES) + len(CONTROLLERS)  # one broadcast per rate, one firmware read per find
    return count


def test_a_sync_discovery_whose_port_fails_at_any_write_leaves_the_bus_at_its_old_rate(write_count: int) -> None:
    for index in range(write_count):
        port = FakeBus(fail_at=index)
        bus = Bus(port, clock=port.clock)
        with pytest.raises(PortError, match="unplugged"):
            bus.run(discover(bus.core, rates=RATES))
        assert port.writes == index + 1  # nothing written after the failure
        assert port.rate == START_RATE and bus.core.baudrate == START_RATE, index
        assert bus.core.timing.assumed_response_time > 0.02  # the walk's timing is not left behind


def test_an_async_discovery_whose_port_fails_at_any_write_leaves_the_bus_at_its_old_rate(write_count: int) -> None:
    async def main() -> None:
        for index in range(write_count):
            port = FakeBus(fail_at=index)
            bus = AsyncBus(port, clock=port.clock)
            with pytest.raises(PortError, match="unplugged"):
                await bus.run(discover(bus.core, rates=RATES))
            assert port.writes == index + 1
            assert port.rate == START_RATE and bus.core.baudrate == START_RATE, index

    asyncio.run(main())


def test_a_baud_change_whose_port_fails_at_any_write_leaves_the_host_at_its_old_rate() -> None:
    controllers = {5: START_RATE}
    clean = FakeBus(controllers=controllers)
    bus = Bus(clean, clock=clean.clock, busy_window=0.01)
    assert bus.run(change_baud(bus.core, 5, 115200)) == 115200
    assert clean.rate == 115200 and clean.controllers[5] == 115200
    for index in range(clean.writes):
        for driver in ("sync", "async"):
            port = FakeBus(fail_at=index, controllers=controllers)
            if driver == "sync":
                sync_bus = Bus(port, clock=port.clock, busy_window=0.01)
                with pytest.raises(PortError):
                    sync_bus.run(change_baud(sync_bus.core, 5, 115200))
                core = sync_bus.core
            else:
                async_bus = AsyncBus(port, clock=port.clock, busy_window=0.01)
                with pytest.raises(PortError):
                    asyncio.run(async_bus.run(change_baud(async_bus.core, 5, 115200)))
                core = async_bus.core
            assert port.rate == START_RATE and core.baudrate == START_RATE, (driver, index)


def test_a_sync_call_timeout_is_thrown_in_and_the_bus_restored() -> None:
    port = FakeBus()
    bus = Bus(port, clock=port.clock)
    with pytest.raises(CallTimeout, match=r"longer than 0\.04 s"):
        bus.run(discover(bus.core, rates=RATES), timeout=0.04)
    assert port.writes < len(RATES)  # abandoned part-way, not run to the end
    assert port.rate == START_RATE and bus.core.baudrate == START_RATE
    assert port.rates_set[-1] == START_RATE and len(port.rates_set) >= 2  # it did switch, then came back
    assert bus.run(discover(bus.core, rates=RATES)) == EXPECTED  # and the bus works after it


@pytest.mark.parametrize("how", ["run_timeout", pytest.param("wait_for", marks=pytest.mark.realtime), "cancel"])
def test_an_async_timeout_or_cancellation_is_thrown_in_and_the_bus_restored(how: str) -> None:
    # wait_for times out on the event loop's (real) clock; the others run on virtual time
    port = FakeBus(clock=REAL_CLOCK if how == "wait_for" else None)

    async def main() -> None:
        bus = AsyncBus(port, clock=port.clock)
        call = bus.run(discover(bus.core, rates=RATES), timeout=0.04 if how == "run_timeout" else None)
        if how == "run_timeout":
            with pytest.raises(CallTimeout):
                await call
        elif how == "wait_for":
            with pytest.raises(TimeoutError):
                await asyncio.wait_for(call, 0.04)
        else:
            task = asyncio.ensure_future(call)
            loop = asyncio.get_running_loop()
            # cancelled while the discovery is part-way (at its third write), from the port's thread
            port.on_write = lambda index: loop.call_soon_threadsafe(task.cancel) if index == 2 else None
            with pytest.raises(asyncio.CancelledError):
                await task
            port.on_write = None
        assert port.rate == START_RATE and bus.core.baudrate == START_RATE
        assert len(port.rates_set) >= 2
        assert await bus.run(discover(bus.core, rates=RATES)) == EXPECTED  # the lock was released

    asyncio.run(main())


def recording(log: list[str]) -> Procedure[str]:
    try:
        yield Send(RequestPing(3).encode())
        yield Wait(0.0)
        log.append("finished")
        return "done"
    except BaseException as err:
        log.append(type(err).__name__)
        raise
    finally:
        log.append("closed")


def drive_sync(procedure: Procedure[str], port: FakeBus) -> str:
    return drive(procedure, port)


def drive_in_loop(procedure: Procedure[str], port: FakeBus) -> str:
    return asyncio.run(drive_async(procedure, port))


@pytest.mark.parametrize("fail_at", [None, 0])
@pytest.mark.parametrize("run", [drive_sync, drive_in_loop])
def test_both_drivers_close_the_procedure(fail_at: int | None, run: Callable[[Procedure[str], FakeBus], str]) -> None:
    log: list[str] = []
    procedure = recording(log)
    port = FakeBus(fail_at=fail_at)
    if fail_at is None:
        assert run(procedure, port) == "done"
        assert log == ["finished", "closed"]
    else:
        with pytest.raises(PortError):
            run(procedure, port)
        assert log == ["PortError", "closed"]  # thrown in at the Send, then closed
    assert inspect.getgeneratorstate(procedure) == inspect.GEN_CLOSED  # nothing left suspended


class Interrupting:
    """A listener that raises KeyboardInterrupt (Ctrl-C) when the first answer byte comes."""

    def record(self, direction: str, data: bytes) -> None:
        if direction == "rx":
            raise KeyboardInterrupt

    def close(self) -> None:
        pass


def test_ctrl_c_in_the_middle_of_a_discovery_is_thrown_in_and_the_bus_restored() -> None:
    port = FakeBus()
    bus = Bus(port, clock=port.clock, listeners=[Interrupting()])
    with pytest.raises(KeyboardInterrupt):
        bus.run(discover(bus.core, rates=RATES))
    assert port.rate == START_RATE and bus.core.baudrate == START_RATE
    assert port.rates_set[-2:] == [115200, START_RATE]  # interrupted where ID 5 answered, then back

    async def main() -> None:
        async_port = FakeBus()
        async_bus = AsyncBus(async_port, clock=async_port.clock, listeners=[Interrupting()])
        with pytest.raises(KeyboardInterrupt):
            await async_bus.run(discover(async_bus.core, rates=RATES))
        assert async_port.rate == START_RATE and async_bus.core.baudrate == START_RATE

    asyncio.run(main())


class Babbling(ScriptedTransport):
    """A line that never stops: every read finds bytes (noise at another rate, a babbling device)."""

    def __init__(self, clock: VirtualClock) -> None:
        super().__init__(lambda data: b"")
        self.clock = clock

    def read(self, max_bytes: int, timeout: float) -> bytes:
        self.clock.sleep(min(timeout, 0.0001))
        return b"\x13"


def test_a_line_that_never_stops_does_not_keep_a_late_read_going() -> None:
    clock = VirtualClock()
    bus = Bus(Babbling(clock), clock=clock, retries=0)
    start = clock.now()
    with pytest.raises(NurimcError):
        bus.request(RequestPing(1))
    deadline = bus.core.timing.answer_deadline(6, 6, 9600, None)
    assert clock.now() - start < deadline + 0.02  # the deadline holds, babbling or not


@pytest.mark.parametrize("seconds", [0.0, 20e-6, SPIN, 0.002])
def test_the_real_clock_lets_at_least_the_time_pass_short_waits_spun_long_ones_slept(
    seconds: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    slept: list[float] = []
    sleep = time.sleep

    def counted(s: float) -> None:
        slept.append(s)
        sleep(s)

    monkeypatch.setattr(time, "sleep", counted)
    started = time.monotonic()
    RealClock().sleep(seconds)
    assert time.monotonic() - started >= seconds
    assert slept == ([seconds] if seconds > SPIN else [])  # a few byte times: no context switch
