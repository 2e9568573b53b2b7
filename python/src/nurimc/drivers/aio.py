"""The asyncio bus: the same core procedures, carried out without blocking the event loop.

Port reads run in a worker thread (pyserial has no async API); everything else — matching,
retries, timeouts, busy windows, motor logic — is the very code the sync Bus runs, and the
driver keeps the same contract (docs/drivers.md).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from ..core.actions import Procedure
from ..core.buscore import BusCore
from ..core.clock import REAL_CLOCK, Clock
from ..core.timing import Timing
from ..procedures.motor import AsyncMotor
from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from ..transport.trafficlog import FrameRecorder
from .options import Listeners, make_core
from .perform import Performer, ReadFor, steps

T = TypeVar("T")

__all__ = ["AsyncBus", "AsyncMotor", "drive_async"]


async def drive_async(
    procedure: Procedure[T],
    transport: Transport,
    listeners: Sequence[FrameRecorder] = (),
    on_note: Callable[[Any], None] | None = None,
    timeout: float | None = None,
    clock: Clock | None = None,
) -> T:
    """Carry out a procedure's actions without blocking the loop (docs/drivers.md).

    The trampoline (`perform.steps`) is the sync driver's; this one awaits what blocks: port
    reads in a worker thread (pyserial has no async API), sleeps on `clock`. A cancellation
    (asyncio.timeout / wait_for on the whole call) is thrown into the procedure, whose cleanup
    still runs on the bus; the cancellation is raised again once the procedure has finished."""
    stepper = steps(procedure, Performer(transport, listeners, on_note, clock), timeout)
    result: Any = None
    error: BaseException | None = None
    while True:
        try:
            block = stepper.send(result) if error is None else stepper.throw(error)
        except StopIteration as stop:
            return stop.value  # type: ignore[no-any-return]
        result, error = None, None
        try:
            if type(block) is ReadFor:
                result = await _read(transport, block)
            else:
                await (clock or REAL_CLOCK).sleep_async(block.seconds)
        except BaseException as err:  # thrown into the procedure at the action that failed
            error = err


async def _read(transport: Transport, block: ReadFor) -> bytes:
    read = asyncio.ensure_future(asyncio.to_thread(transport.read, block.max_bytes, block.seconds))
    try:
        return await asyncio.shield(read)
    except asyncio.CancelledError:
        # the read goes on in its thread: let it end before anything else uses the port
        await asyncio.wait([read])
        raise


class AsyncBus:
    """`async with AsyncBus.open(url) as bus: await bus.motor(1).read_state()`

    Takes the options of the sync Bus (busy_window, busy_windows, late_answer, log_path,
    tracer, listeners, ...), with the same meaning."""

    def __init__(
        self,
        transport: Transport,
        retries: int = 2,
        timing: Timing | None = None,
        log_path: str | None = None,
        tracer: FrameRecorder | None = None,
        listeners: Sequence[FrameRecorder] = (),
        clock: Clock | None = None,
        **options: Any,
    ) -> None:
        self.transport = transport
        self.clock: Clock = clock or REAL_CLOCK
        self.core: BusCore = make_core(transport, retries, timing, options)
        self._lock = asyncio.Lock()
        self._listeners = Listeners(log_path, tracer, listeners)

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> AsyncBus:
        latency, rs485 = options.pop("latency", None), options.pop("rs485", None)
        return cls(open_transport(url, baudrate, latency, rs485, options.pop("reconnect", False)), **options)

    @property
    def listeners(self) -> list[FrameRecorder]:
        return self._listeners.items

    def add_listener(self, listener: FrameRecorder) -> None:
        self._listeners.items.append(listener)

    def remove_listener(self, listener: FrameRecorder) -> None:
        self._listeners.items.remove(listener)

    @property
    def baudrate(self) -> int:
        return self.core.baudrate

    @property
    def stats(self) -> Any:
        return self.core.stats

    async def set_baudrate(self, rate: int) -> None:
        await self.run(self.core.set_baud(rate))

    async def run(
        self, procedure: Procedure[T], on_note: Callable[[Any], None] | None = None, timeout: float | None = None
    ) -> T:
        """Run any procedure under the bus lock; `timeout` as Bus.run. Cancelling the awaiting
        task (asyncio.timeout, wait_for) throws CancelledError into the procedure, whose
        cleanup runs before the cancellation goes on (docs/drivers.md)."""
        async with self._lock:
            return await drive_async(procedure, self.transport, self._listeners.items, on_note, timeout, self.clock)

    async def request(self, request: Request, retries: int | None = None) -> Message:
        return await self.run(self.core.ask(request, retries))

    async def send(self, *commands: Command) -> None:
        await self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str | None = None) -> AsyncMotor:
        """A handle for one controller. Without `product`: the product line discovery found for the
        ID on this bus (nurimc.procedures.products), else MC."""
        return AsyncMotor(self, device_id, product or self.core.products.get(device_id, "mc"))

    async def close(self) -> None:
        async with self._lock:
            try:
                self.transport.close()
            finally:
                self._listeners.close()

    async def __aenter__(self) -> AsyncBus:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()
