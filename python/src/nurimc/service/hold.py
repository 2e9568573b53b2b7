"""A program that holds a port shares it (docs/service.md): one call starts the service and
serves it on the port's socket; `close()` tells every attached program."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from ..drivers.sync import Bus
from .core import BusService
from .share import ShareError, ShareServer, shareable


class Holding:
    """The bus service of a holder program, and its server (None if it could not serve)."""

    def __init__(self, service: BusService, server: ShareServer | None) -> None:
        self.service = service
        self.server = server

    def close(self, why: str) -> None:
        if self.server is not None:
            self.server.close(why)
        self.service.close()


def hold_port(
    bus: Bus,
    port: str,
    motors: Mapping[int, int],
    program: str,
    say: Callable[[str], None],
    on_event: Callable[[dict[str, Any]], None] | None = None,
    motor_source: Callable[[], Mapping[int, int]] | None = None,
    service: BusService | None = None,
) -> Holding:
    """Start a BusService on `bus` (its own thread) and serve it to other nurimc programs.
    `motor_source`: the program's own list of motors, read at each emergency stop. `service`: the
    program's own service (it is a client of it already: the bridge), served instead of a new one."""
    if service is None:
        service = BusService(bus, motors=motors, say=say, program=program, say_port=False)  # the program says them
    else:
        service.add_motors(motors)
    service.motor_source = motor_source
    if on_event is not None:
        service.listen(on_event)
    service.start()
    if not shareable(port):  # an in-process simulator: another program opening it gets a bus of its own
        return Holding(service, None)
    try:
        server: ShareServer | None = ShareServer(service, port, say=say).start()
    except (ShareError, OSError) as error:
        say(f"the port is not shared with other nurimc programs: {error}")
        server = None
    return Holding(service, server)
