"""Handles: a motor or group API written once, run on a sync or an async bus.

A handle class declares each call as `HandleCall(Procedures.method)`, a descriptor that runs
the procedure on the handle's bus: on a sync handle it returns the result, on an async handle
an awaitable. The buses are named here only as protocols (`SyncRunner`, `AsyncRunner`): the
drivers hand out handles, so the handles must not import the drivers.
"""

from __future__ import annotations

import functools
from collections.abc import Awaitable, Callable
from typing import Any, Concatenate, Generic, ParamSpec, Protocol, TypeVar, overload

from .actions import Procedure
from .buscore import BusCore

P = ParamSpec("P")
T = TypeVar("T")


class SyncRunner(Protocol):
    """What a sync handle needs of its bus (nurimc.drivers.sync.Bus). A protocol, not an
    import: the buses hand out motors, so motor must not import them (no import cycle)."""

    @property
    def core(self) -> BusCore: ...
    def run(self, procedure: Procedure[T]) -> T: ...


class AsyncRunner(Protocol):
    """What an async handle needs of its bus (nurimc.drivers.aio.AsyncBus)."""

    @property
    def core(self) -> BusCore: ...
    async def run(self, procedure: Procedure[T]) -> T: ...


class SyncHandle:
    """A handle whose calls run now and return their result."""

    bus: SyncRunner


class AsyncHandle:
    """A handle whose calls return awaitables."""

    bus: AsyncRunner


class HandleCall(Generic[P, T]):
    """One handle call, written once: runs its procedure on the handle's bus, sync or async.
    The handle's `procedures` (MotorProcedures, GroupProcedures) is the procedure's `self`."""

    def __init__(
        self,
        procedure: Callable[Concatenate[Any, P], Procedure[T]],
        in_place: Callable[Concatenate[Any, Any, P], T] | None = None,
    ) -> None:
        self.procedure = procedure
        #: the call on a sync bus that runs single requests in place (drivers/fastpath.py):
        #: in_place(bus, procedures, *args) does what the procedure does, through bus._request_then
        self.in_place = in_place
        self.__doc__ = procedure.__doc__
        self.name = procedure.__name__

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, handle: None, owner: type) -> HandleCall[P, T]: ...
    @overload
    def __get__(self, handle: SyncHandle, owner: type) -> Callable[P, T]: ...
    @overload
    def __get__(self, handle: AsyncHandle, owner: type) -> Callable[P, Awaitable[T]]: ...
    def __get__(self, handle: object, owner: type) -> Any:
        if handle is None:
            return self
        procedure = self.procedure
        procedures = handle.procedures  # type: ignore[attr-defined]
        bus = handle.bus  # type: ignore[attr-defined]
        run = bus.run
        in_place = self.in_place
        call: Callable[P, Any]
        if in_place is not None and getattr(bus, "_request_then", None) is not None:
            call = functools.wraps(procedure)(functools.partial(in_place, bus, procedures))  # no frame of its own

        else:

            @functools.wraps(procedure)
            def call(*args: P.args, **kwargs: P.kwargs) -> Any:
                return run(procedure(procedures, *args, **kwargs))

        # made once per handle: kept in the handle, where it is found before this descriptor
        # (a handle's procedures and bus never change); a handle with __slots__ makes it each time
        own = getattr(handle, "__dict__", None)
        if own is not None:
            own[self.name] = call
        return call
