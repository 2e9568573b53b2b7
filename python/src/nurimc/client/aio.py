"""The asyncio bus: the same core procedures, carried out without blocking the event loop.

Port reads run in a worker thread (pyserial has no async API); everything else — matching,
retries, timeouts, motor logic — is the very code the sync Bus runs.
"""

from __future__ import annotations

import asyncio
from typing import Any, TypeVar

from ..motor import MotorProcedures, MotorState
from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from .actions import Procedure, Receive, Wait
from .core import BusCore
from .perform import Performer
from .timing import Timing

T = TypeVar("T")


async def drive_async(procedure: Procedure[T], transport: Transport) -> T:
    performer = Performer(transport)
    result: Any = None
    try:
        action = procedure.send(None)
        while True:
            if type(action) is Receive:
                remaining = performer.remaining(action.deadline)
                if remaining > 0:
                    result = await asyncio.to_thread(transport.read, action.max_bytes, remaining)
                else:
                    result = b""
            elif type(action) is Wait:
                await asyncio.sleep(action.seconds)
                result = None
            else:
                result = performer.perform(action)
            action = procedure.send(result)
    except StopIteration as stop:
        return stop.value  # type: ignore[no-any-return]


class AsyncBus:
    """`async with AsyncBus.open(url) as bus: await bus.motor(1).read_state()`"""

    def __init__(self, transport: Transport, retries: int = 2, timing: Timing | None = None) -> None:
        self.transport = transport
        self.core = BusCore(
            baudrate=transport.baudrate, retries=retries, timing=timing or Timing(latency=transport.latency)
        )
        self._lock = asyncio.Lock()

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> AsyncBus:
        latency = options.pop("latency", None)
        return cls(open_transport(url, baudrate, latency), **options)

    async def run(self, procedure: Procedure[T]) -> T:
        async with self._lock:
            return await drive_async(procedure, self.transport)

    async def request(self, request: Request, retries: int | None = None) -> Message:
        return await self.run(self.core.ask(request, retries))

    async def send(self, *commands: Command) -> None:
        await self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str = "mc") -> AsyncMotor:
        return AsyncMotor(self, device_id, product)

    async def close(self) -> None:
        async with self._lock:
            self.transport.close()

    async def __aenter__(self) -> AsyncBus:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()


class AsyncMotor:
    """The async twin of nurimc.Motor: same procedures, awaited."""

    def __init__(self, bus: AsyncBus, device_id: int, product: str = "mc") -> None:
        self.bus = bus
        self.id = device_id
        self.procedures = MotorProcedures(bus.core, device_id, product)

    async def move_to(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> None:
        await self.bus.run(self.procedures.move_to(degrees, rpm, seconds))

    async def move_by(self, degrees: float, rpm: float | None = None, seconds: float | None = None) -> None:
        await self.bus.run(self.procedures.move_by(degrees, rpm, seconds))

    async def run(self, rpm: float, ramp_seconds: float = 0.1) -> None:
        await self.bus.run(self.procedures.run(rpm, ramp_seconds))

    async def release(self) -> None:
        await self.bus.run(self.procedures.release())

    async def hold(self) -> None:
        await self.bus.run(self.procedures.hold())

    async def read_state(self) -> MotorState:
        return await self.bus.run(self.procedures.read_state())

    async def get(self, name: str) -> Any:
        return await self.bus.run(self.procedures.get(name))

    async def set(self, name: str, value: object) -> Any:
        return await self.bus.run(self.procedures.set(name, value))
