"""`nurimc serve`, `nurimc clients`, `nurimc estop`: the shared bus (docs/service.md)."""

from __future__ import annotations

import contextlib
import os
import sys
import time
from typing import Any

import typer

from .common import EXIT_DEVICE, EXIT_OK, emit, fail, note, options, out, say_line, stop_flag, table
from .i18n import tr


def port_of(o: Any) -> str:
    port: str | None = o.port or os.environ.get("NURIMC_PORT")
    if not port:
        fail("no port: give --port (e.g. /dev/ttyUSB0, socket://host:port, sim://?ids=1,2) or set NURIMC_PORT")
    return port


def _discover_motors(service: Any, baud: int) -> dict[int, int]:
    found = service.discover([baud])
    return {f.id: f.baudrate for f in found}


def serve(ctx: typer.Context) -> None:
    """Hold a port with no interface of its own and share it with other nurimc programs.

    The motors of --id (else those found at --baud) are known to the emergency stop. Other
    programs on this machine that open the same port attach to this one (`nurimc --port P
    status`, `watch`, `record`, `estop`, `clients`).

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 serve
    """
    o = options(ctx)
    port = port_of(o)
    from ..service import BusService
    from ..service.share import ShareError, ShareServer, connect, socket_path
    from .common import open_bus  # attaching to a holder would be pointless here: refused below

    with contextlib.suppress(ShareError):
        held = connect(port, "nurimc serve")
        if held is not None:
            held.close()
            fail(f"another nurimc program already holds {port}: attach to it instead (see `nurimc clients`)")
    bus = open_bus(o, reconnect=True, attach=False)
    service = BusService(bus, say=say_line, program="nurimc serve").start()
    try:
        server = ShareServer(service, port, say=say_line).start()
    except ShareError as error:
        service.close()
        bus.close()
        fail(str(error), EXIT_DEVICE)
    try:
        motors = {i: o.baud for i in o.ids} if o.ids else _discover_motors(service, o.baud)
        service.add_motors(motors)
        ids = ", ".join(map(str, sorted(motors))) or "none found"
        out.print(
            tr(f"ready: serving {port} at {bus.baudrate} bps on {socket_path(port)} (motors: {ids}; Ctrl-C ends)"),
            soft_wrap=True,
        )
        sys.stdout.flush()
        with stop_flag() as stopped:
            stopped.wait()
    finally:
        server.close("the holder (nurimc serve) ended")
        service.close()
        bus.close()


def clients(ctx: typer.Context) -> None:
    """List the programs attached to the holder of --port (program, PID, since, requests, polls).

    Example: nurimc --port /dev/ttyUSB0 clients
    """
    o = options(ctx)
    port = port_of(o)
    from ..service.share import ShareError, connect

    try:
        conn = connect(port, "nurimc clients")
    except ShareError as error:
        fail(str(error), EXIT_DEVICE)
    if conn is None:
        fail(
            f"no nurimc program holds {port}: nothing is attached (start one with `nurimc serve`)",
            EXIT_DEVICE,
        )
    try:
        rows: list[dict[str, Any]] = conn.call("clients", timeout=10)
    finally:
        conn.close()
    rows = [r for r in rows if r.get("pid") != os.getpid()]
    view = table(f"programs using {port}", "program", "PID", "since", "requests", "polls")

    for r in rows:
        since = time.strftime("%H:%M:%S", time.localtime(float(r["since"])))
        view.add_row(str(r["program"]), str(r["pid"]), since, str(r["requests"]), str(r["polls"]))
    emit(o, rows, view)


def estop(ctx: typer.Context) -> None:
    """Emergency stop: control off to every motor of the bus, read back (exit 0 only when every motor reads off).

    Through the holder of --port if a nurimc program holds it (it knows every motor and latches
    the stop for every program); else on the port itself: the motors of --id, or those found
    at --baud. Motors that could not be read back are named.

    Example: nurimc --port /dev/ttyUSB0 estop
    """
    o = options(ctx)
    port = port_of(o)
    from ..service import StopResult
    from ..service.share import ShareError, connect, shareable

    try:
        conn = connect(port, "nurimc estop") if shareable(port) else None
    except ShareError as error:
        conn = None
        note(f"{error}; stopping on the port itself")
    if conn is not None:
        try:
            data: dict[str, Any] = conn.call("estop", timeout=60)
        finally:
            conn.close()
        result = StopResult(tuple(data["stopped"]), tuple(data["not_confirmed"]), tuple(data["rates"]), data["control"])
    else:
        result = _stop_here(o)
    emit(o, result.as_dict(), result.text())
    raise typer.Exit(EXIT_OK if result.ok else EXIT_DEVICE)


def _stop_here(o: Any) -> Any:
    from ..errors import NurimcError
    from ..service import BusService
    from .common import open_bus

    bus = open_bus(o, attach=False)
    with bus:
        service = BusService(bus, motors={i: o.baud for i in o.ids}, program="nurimc estop")
        if not o.ids:  # control off first, then find out who is there to read back
            with contextlib.suppress(NurimcError):
                service.emergency_stop()
            service.add_motors(_discover_motors(service, o.baud))
        return service.emergency_stop()


def register(app: typer.Typer) -> None:
    app.command()(serve)
    app.command()(clients)
    app.command()(estop)
