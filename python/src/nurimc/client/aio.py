"""The asyncio bus: the same core procedures, carried out without blocking the event loop.

Port reads run in a worker thread (pyserial has no async API); everything else — matching,
retries, timeouts, busy windows, motor logic — is the very code the sync Bus runs, and the
driver keeps the same contract (docs/drivers.md).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from ..errors import CallTimeout
from ..motor import AsyncMotor
from ..protocol import Command, Message, Request
from ..transport import Transport, open_transport
from .actions import Action, Procedure, Receive, Wait, WaitUntil
from .core import BusCore
from .log import FrameRecorder
from .perform import Performer
from .sync import Listeners, make_core
from .timing import Timing

T = TypeVar("T")

__all__ = ["AsyncBus", "AsyncMotor", "drive_async"]


async def drive_async(
    procedure: Procedure[T],
    transport: Transport,
    listeners: Sequence[FrameRecorder] = (),
    on_note: Callable[[Any], None] | None = None,
    timeout: float | None = None,
) -> T:
    """Carry out a procedure's actions without blocking the loop (docs/drivers.md).

    A failing action or a cancellation (including asyncio.timeout / wait_for on the whole
    call) is thrown into the procedure, whose cleanup then still runs on the bus; the
    cancellation is raised again once the procedure has finished. `timeout`: as the sync
    driver, CallTimeout is thrown in at the first blocking action after that many seconds."""
    performer = Performer(transport, listeners, on_note)
    call_deadline = None if timeout is None else time.monotonic() + timeout
    result: Any = None
    error: BaseException | None = None
    try:
        while True:
            try:
                action: Action = procedure.send(result) if error is None else procedure.throw(error)
            except StopIteration as stop:
                return stop.value  # type: ignore[no-any-return]
            result, error = None, None
            try:
                blocking = type(action) in (Receive, Wait, WaitUntil)
                if blocking and call_deadline is not None and time.monotonic() >= call_deadline:
                    call_deadline = None  # thrown once; the procedure's cleanup may still use the bus
                    raise CallTimeout(f"the bus call took longer than {timeout:g} s and was abandoned")
                result = await _perform(performer, transport, action, call_deadline)
            except BaseException as err:  # every failure goes to the procedure
                error = err
    finally:
        procedure.close()


async def _perform(performer: Performer, transport: Transport, action: Action, call_deadline: float | None) -> Any:
    if type(action) is Receive:
        wait = performer.read_timeout(action.until if call_deadline is None else min(action.until, call_deadline))
        if wait is None:
            return b""
        read = asyncio.ensure_future(asyncio.to_thread(transport.read, action.max_bytes, wait))
        try:
            return performer.received(await asyncio.shield(read))
        except asyncio.CancelledError:
            # the read goes on in its thread: let it end before anything else uses the port
            await asyncio.wait([read])
            raise
    if type(action) is Wait:
        seconds = action.seconds if call_deadline is None else min(action.seconds, call_deadline - time.monotonic())
        await asyncio.sleep(max(0.0, seconds))
        return None
    if type(action) is WaitUntil:
        when = action.when if call_deadline is None else min(action.when, call_deadline)
        await asyncio.sleep(max(0.0, when - time.monotonic()))
        return time.monotonic()
    return performer.perform(action)


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
        **options: Any,
    ) -> None:
        self.transport = transport
        self.core: BusCore = make_core(transport, retries, timing, options)
        self._lock = asyncio.Lock()
        self._listeners = Listeners(log_path, tracer, listeners)

    @classmethod
    def open(cls, url: str, baudrate: int = 9600, **options: Any) -> AsyncBus:
        latency, rs485 = options.pop("latency", None), options.pop("rs485", None)
        return cls(open_transport(url, baudrate, latency, rs485), **options)

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
            return await drive_async(procedure, self.transport, self._listeners.items, on_note, timeout)

    async def request(self, request: Request, retries: int | None = None) -> Message:
        return await self.run(self.core.ask(request, retries))

    async def send(self, *commands: Command) -> None:
        await self.run(self.core.tell(*commands))

    def motor(self, device_id: int, product: str | None = None) -> AsyncMotor:
        """A handle for one controller. Without `product`: the product line discovery found for the
        ID on this bus (nurimc.products), else MC."""
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
