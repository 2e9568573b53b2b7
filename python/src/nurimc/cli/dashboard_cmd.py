"""`nurimc dashboard`: the web console (docs/dashboard.md)."""

from __future__ import annotations

import os
import socket
from typing import Any

import typer

from ..drivers.sync import Bus
from ..transport.outage import OutageGuard
from .common import EXIT_USAGE, fail, open_bus, options, out, say_line


def dashboard(
    ctx: typer.Context,
    sim: bool = typer.Option(False, "--sim", help="Run on a simulated bus (three motors) instead of --port."),
    listen: str = typer.Option("127.0.0.1:8485", "--listen", help="HOST:PORT to serve on (port 0: any free port)."),
    token: str = typer.Option(
        None, "--token", envvar="NURIMC_DASHBOARD_TOKEN", help="Secret the page must present; required off loopback."
    ),
    allow_host: list[str] = typer.Option([], "--allow-host", help="Another name this server is reached by."),
    allow_any_port: bool = typer.Option(
        False,
        "--allow-any-port",
        help="Let the page open any port URL (spy://, socket://, sim://?state=...): files and network as this user.",
    ),
) -> None:
    """Serve the web console: discover, plot, drive, tune, back up; emergency stop.

    Example: nurimc --port /dev/ttyUSB0 --baud 115200 dashboard   (then open http://127.0.0.1:8485)
    """
    from ..extras import missing_extra

    hint = missing_extra("dashboard")
    if hint:
        fail(hint, EXIT_USAGE)  # printed as plain text (say_error): no markup escaping
    import uvicorn

    from ..dashboard import DashboardConfig, create_app
    from ..dashboard.frames import FrameTap
    from ..dashboard.security import ListenError, SecurityPolicy, parse_listen

    o = options(ctx)
    from ..dashboard.server import MISSING_ASSETS, STATIC, UPLOT, uvicorn_options

    if not (STATIC / UPLOT).is_file():
        fail(MISSING_ASSETS, EXIT_USAGE)
    try:
        address = parse_listen(listen)
        policy = SecurityPolicy.build(address, token, tuple(allow_host), any_port=allow_any_port)
    except ListenError as error:
        fail(str(error), EXIT_USAGE)
    tap = FrameTap()
    sim_bus = None
    holding = None
    if sim:
        from ..dashboard.simulated import simulated_bus

        sim_bus, bus = simulated_bus(tap)
        port_name = "sim://"
    else:
        port_name = o.port or os.environ.get("NURIMC_PORT", "")
        bus, holding = console_bus(o, tap, port_name)  # attached to a holder, or holding and sharing the port

    family = socket.AF_INET6 if ":" in address.host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((address.host, address.port))
    except OSError as error:
        fail(f"cannot listen on {listen}: {error.strerror}; pick another --listen HOST:PORT", EXIT_USAGE)
    sock.listen(1024)  # a flood of connections does not keep a new page's out of the queue
    port = sock.getsockname()[1]
    shown = f"[{address.host}]" if family == socket.AF_INET6 else address.host
    url = f"http://{shown}:{port}/" + (f"?token={token}" if token else "")

    def ready() -> None:
        out.print(f"ready: {url}", soft_wrap=True)

    config = DashboardConfig(
        bus=bus, tap=tap, policy=policy, product=o.product, sim=sim, port=port_name, on_ready=ready
    )
    if holding is not None:
        config.on_worker = lambda worker: share_with_pages(holding, worker)
    elif hasattr(bus, "conn"):  # attached to another program's port: what it tells goes to the pages too
        config.on_worker = lambda worker: holder_to_pages(bus, worker)
    from ..dashboard.connlimits import ConnectionLimits, server_options

    limits = ConnectionLimits.for_this_process()  # raises the descriptor limit too
    options_ = {**uvicorn_options(), **server_options(limits)}
    server = uvicorn.Server(uvicorn.Config(create_app(config), log_level="warning", **options_))
    outage = OutageGuard(bus.transport, say_line)  # lost and back: one line each
    try:
        server.run(sockets=[sock])
    finally:
        lost = outage.port_lost_at_exit()
        if lost:
            say_line(lost)
        if holding is not None:
            holding.close("the holder (nurimc dashboard) ended")
        bus.close()
        if sim_bus is not None:
            sim_bus.close()


def share_with_pages(holding: Any, worker: Any) -> None:
    """The console holds the port: the motors it found are stopped by an estop from any attached
    program, and such a stop is shown on every page (its banner), as the console's own."""
    holding.service.motor_source = lambda: worker.known

    def told(event: dict[str, Any]) -> None:
        if event.get("type") == "estop" and event.get("from") != "nurimc dashboard":
            worker.turning.clear()
            worker.publish({**event, "type": "estop", "generation": worker.generation, "from": "another program"})

    holding.service.listen(told)
    publish = worker.publish

    def to_pages_and_programs(event: dict[str, Any]) -> None:  # the console's own E-STOP: attached programs told
        publish(event)
        if event.get("type") == "estop" and "from" not in event:
            holding.service.announce({**event, "from": "nurimc dashboard"})

    worker.publish = to_pages_and_programs


def holder_to_pages(bus: Any, worker: Any) -> None:
    """The console attached to a holder: an emergency stop from any program shows on every page
    (the banner), and the holder's end is said there as a lost port is."""
    said = bus.conn.on_event

    def told(event: dict[str, Any]) -> None:
        if said is not None:
            said(event)
        if event.get("type") == "estop":
            worker.turning.clear()
            worker.publish({**event, "type": "estop", "generation": worker.generation, "from": "another program"})
        elif event.get("type") == "closed":
            worker.publish(
                {"type": "port", "state": "lost", "up": False, "port": worker.port, "text": event.get("message")}
            )

    bus.conn.on_event = told


def console_bus(o: Any, tap: Any, port_name: str) -> tuple[Bus, Any]:
    """The console's bus: attached when another nurimc program holds the port (docs/service.md),
    else its own (reopened when lost: docs/dashboard.md), served to other programs."""
    from ..service.hold import hold_port
    from ..service.share import AttachedBus

    opened = open_bus(o, reconnect=True)
    if isinstance(opened, AttachedBus):
        opened.add_listener(tap)
        return opened, None
    bus = Bus(opened.transport, tracer=tap)
    return bus, hold_port(bus, port_name, {}, "nurimc dashboard", say_line)


def register(app: typer.Typer) -> None:
    app.command()(dashboard)
