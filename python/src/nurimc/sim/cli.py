"""The simulator's command line: `nurimc sim ...` and `python -m nurimc.sim ...` (same options)."""

from __future__ import annotations

import logging
import math
import signal
import sys
import threading
from typing import Annotated, Any

import typer

from ..cli.i18n import tr
from .background import detach
from .background import ready as background_ready
from .bus import SimBus, describe
from .faults import FaultConfig
from .options import OptionError, check_baud, parse_ids, parse_motor
from .plant import apply_plants as plants_onto
from .profile import SPEED_ZERO_CHOICES, SimProfile, load_profiles
from .settings import PRODUCT_NAMES
from .store import StateError


def sim(
    link: Annotated[str | None, typer.Option(help="Create a symlink at PATH to the pseudo-terminal.")] = None,
    monitor: Annotated[
        str | None,
        typer.Option(help="Also serve a monitor pty at PATH (a symlink) that hears both directions, for a sniffer."),
    ] = None,
    tcp: Annotated[
        int | None,
        typer.Option(
            help="Also serve TCP here: socket:// (raw, at --baud) or rfc2217:// (sets its own rate); 0 picks one."
        ),
    ] = None,
    host: Annotated[str, typer.Option(help="Address the TCP server listens on.")] = "127.0.0.1",
    ids: Annotated[
        str | None, typer.Option(help="Controller IDs: '1' (ID 1), '0,1,2', or a range '0-31'. Default: ID 0.")
    ] = None,
    baud: Annotated[int, typer.Option(help="Rate of the --ids controllers (and of raw TCP clients).")] = 9600,
    motor: Annotated[
        list[str] | None,
        typer.Option(
            help="A controller at its own rate and product, ID@RATE[:PRODUCT] (repeatable), "
            "e.g. 3@57600 or 7@57600:rsa."
        ),
    ] = None,
    product: Annotated[
        str,
        typer.Option(
            help="Product of the --ids controllers (and of --motor without :PRODUCT): "
            + ", ".join(PRODUCT_NAMES)
            + ". sm speaks the vendor C# table (sm-cs); sm-readme the README table."
        ),
    ] = "mc",
    resolution: Annotated[
        int | None,
        typer.Option(
            help="Encoder pulses per motor turn (MC, and RSA/RSAVW/SA/SM, which have no resolution setting: "
            "default 1024, 4 counts each: 0.088° steps) or hall poles (BLMC-H; default 8, 3 steps each). "
            "The document's factory value, 4, gives 22.5° steps. "
            "A controller restored from --state keeps its stored values."
        ),
    ] = None,
    profile: Annotated[
        str | None,
        typer.Option(help="Product profiles file shaped like spec/profiles.json (factory gains, speed-0 rule)."),
    ] = None,
    speed_zero: Annotated[
        str | None,
        typer.Option(
            help="What a motion frame with speed 0 does: stop (the default: decelerate to a stop over the "
            "arrival time, as the vendor's simulator) or ignore (the document's range starts at 1)."
        ),
    ] = None,
    plant: Annotated[
        list[str] | None,
        typer.Option(
            help="Plant of controller ID, ID:KEY=VALUE[,KEY=VALUE...] (repeatable): inertia, viscous, coulomb "
            "(multiples of the default motor), backlash (deg), noise (deg std of the reading), delay (s). "
            "E.g. 1:inertia=3,backlash=0.5 (docs/simulator.md)."
        ),
    ] = None,
    state: Annotated[str | None, typer.Option(help="Directory that keeps the settings across restarts.")] = None,
    wire_timing: Annotated[bool, typer.Option("--wire-timing", help="Pace bytes as a real wire would.")] = False,
    drop_rate: Annotated[float, typer.Option(help="Probability a byte on the wire is lost.")] = 0.0,
    flip_rate: Annotated[float, typer.Option(help="Probability a byte on the wire gets a bit flipped.")] = 0.0,
    noise_rate: Annotated[float, typer.Option(help="Probability of a noise burst before a byte the host gets.")] = 0.0,
    delay_ms: Annotated[float, typer.Option(help="Delay answers by this many ms (see --delay-rate).")] = 0.0,
    delay_rate: Annotated[float, typer.Option(help="Probability an answer is delayed by --delay-ms.")] = 1.0,
    miss_rate: Annotated[float, typer.Option(help="Probability an answer never comes.")] = 0.0,
    same_sum_rate: Annotated[
        float, typer.Option(help="Probability a frame to the host has two bytes changed that keep its checksum.")
    ] = 0.0,
    echo: Annotated[bool, typer.Option("--echo", help="The adapter echoes the host's own bytes.")] = False,
    seed: Annotated[int, typer.Option(help="Seed of the fault generator (same seed, same faults).")] = 0,
    eeprom_ms: Annotated[float, typer.Option(help="How long a settings write keeps a controller busy.")] = 50.0,
    verbose: Annotated[bool, typer.Option("-v", "--verbose", help="Log every frame received and sent.")] = False,
    background: Annotated[
        bool,
        typer.Option(
            "--background", help="Wait until the bus is served, print the ready lines, then run on in the background."
        ),
    ] = False,
) -> None:
    """Simulated controllers (MC, BLMC-H, RSA, RSAVW, SA, SM) on a simulated RS485 bus, on a pseudo-terminal and/or TCP.

    Example: nurimc sim --link /tmp/nurimc0 --ids 1,2 --motor 3@57600 --wire-timing

    In a script or the quick start: nurimc sim --link /tmp/nurimc0 --ids 1,2 --background

    Mixed product lines, each at its own rate:
    nurimc sim --link /tmp/nurimc0 --motor 1@9600:mc --motor 7@57600:rsa --motor 9@115200:sm
    """
    if background:
        detach()  # the parent returns from here only through sys.exit, once the child is ready
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(asctime)s.%(msecs)03d %(message)s",
        datefmt="%H:%M:%S",
        stream=sys.stderr,
    )
    try:
        check_serving(tcp, eeprom_ms, speed_zero, link, monitor)
        profiles = load_profiles(profile) if profile is not None else None
        bus = build_bus(
            ids,
            baud,
            motor or [],
            product,
            state,
            wire_timing,
            seed,
            _faults(locals()),
            eeprom_ms,
            speed_zero,
            profiles,
            resolution,
        )
        apply_plants(bus, plant or [])
    except (OptionError, StateError, ValueError) as exc:
        typer.echo(f"nurimc sim: {tr(str(exc))}", err=True)  # in the CLI's language (docs/cli.md)
        raise typer.Exit(2) from None
    serve(bus, link, tcp, host, baud, monitor)


def apply_plants(bus: SimBus, texts: list[str]) -> None:
    """Each --plant ID:KEY=VALUE,... onto the controllers with that ID (closes the bus on a bad one)."""
    try:
        plants_onto(bus.controllers, texts)
    except BaseException:
        bus.close()
        raise


def check_serving(
    tcp: int | None, eeprom_ms: float, speed_zero: str | None, link: str | None, monitor: str | None
) -> None:
    """The options build_bus does not see, checked before anything is served."""
    if tcp is not None and not 0 <= tcp <= 65535:
        raise OptionError(f"--tcp {tcp}: a TCP port is 0..65535 (0 picks a free one)")
    if not (math.isfinite(eeprom_ms) and 0 <= eeprom_ms <= 10_000):
        raise OptionError(f"--eeprom-ms {eeprom_ms}: use a number of milliseconds, 0..10000")
    if speed_zero is not None and speed_zero not in SPEED_ZERO_CHOICES:
        raise OptionError(f"--speed-zero {speed_zero!r}: use one of {', '.join(SPEED_ZERO_CHOICES)}")
    if link is not None and monitor is not None and link == monitor:
        raise OptionError(f"--link and --monitor are both {link}; give them different paths")


def _faults(options: dict[str, Any]) -> FaultConfig:
    names = ("drop_rate", "flip_rate", "noise_rate", "delay_ms", "delay_rate", "miss_rate", "same_sum_rate", "echo")
    return FaultConfig(**{n: options[n] for n in names})


def build_bus(
    ids: str | None,
    baud: int,
    motors: list[str],
    product: str,
    state: str | None,
    wire_timing: bool,
    seed: int,
    faults: FaultConfig,
    eeprom_ms: float = 50.0,
    speed_zero: str | None = None,
    profiles: dict[str, SimProfile] | None = None,
    resolution: int | None = None,
) -> SimBus:
    if product not in PRODUCT_NAMES:
        raise OptionError(f"--product {product!r}: use one of {', '.join(PRODUCT_NAMES)}")
    check_baud(baud)
    id_list = parse_ids(ids if ids is not None else ("" if motors else "0"))
    motor_list = [parse_motor(text) for text in motors]
    if not id_list and not motor_list:
        raise OptionError("no controllers: give --ids or --motor")
    if len(id_list) + len(motor_list) > 254:
        raise OptionError(f"{len(id_list) + len(motor_list)} controllers: a bus holds at most 254")
    bus = SimBus(
        wire_timing=wire_timing,
        faults=faults,
        state_dir=state,
        seed=seed,
        eeprom_time=eeprom_ms / 1000,
        speed_zero=speed_zero,
        profiles=profiles,
    )
    try:
        for i in id_list:
            bus.add_controller(i, baud, product)
        for i, rate, own in motor_list:
            bus.add_controller(i, rate, own or product)
        for controller in bus.controllers:
            encoder_like(controller, controller.product, resolution)
    except BaseException:
        bus.close()
        raise
    return bus


#: `nurimc sim`'s resolution when none is given: what a real motor reports (an encoder of 1024
#: pulses on an MC and on the lines without a resolution setting, 8 hall poles on a BLMC-H),
#: not the document's factory 4 (22.5° steps).
SIM_RESOLUTION = {"blmc-h": 8}
ENCODER_RESOLUTION = 1024
FACTORY_RESOLUTION = 4


def encoder_like(controller: Any, product: str, resolution: int | None) -> None:
    """Give a controller the --resolution (or the encoder-like default) unless it was restored
    from --state: a stored controller keeps every value as stored (a stored 4 stays 4)."""
    if resolution is not None and not 1 <= resolution <= 65533:
        raise OptionError(f"--resolution {resolution}: use 1..65533 (encoder pulses or hall poles)")
    if getattr(controller, "restored", False):
        return
    controller.settings.resolution = resolution or SIM_RESOLUTION.get(product, ENCODER_RESOLUTION)
    controller.apply_settings()


def serve(bus: SimBus, link: str | None, tcp: int | None, host: str, baud: int, monitor: str | None = None) -> None:
    """Serve until SIGINT or SIGTERM; print what is served and `ready: ...` lines (flushed)."""
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    servers: list[Any] = []
    ready: list[str] = []
    try:
        if link is not None or tcp is None:
            endpoint = bus.serve_pty(link=link)
            servers.append(endpoint)
            ready.append(link or endpoint.path)
            print(f"pseudo-terminal {endpoint.path}" + (f" (link {link})" if link else ""))
        if tcp is not None:
            server = bus.serve_tcp(port=tcp, host=host, baud=baud)
            servers.append(server)
            address = f"{server.address[0]}:{server.address[1]}"
            ready.append(address)
            print(f"tcp {address} (socket://{address} talks at {baud} bps; rfc2217://{address} sets its own rate)")
        if monitor is not None:
            watcher = bus.serve_monitor(link=monitor)
            servers.append(watcher)
            ready.append(monitor)
            print(f"monitor {watcher.path} (link {monitor}): hears the host and the controllers")
    except OSError as exc:
        for s in servers:
            s.stop()
        bus.close()
        typer.echo(f"nurimc sim: cannot serve: {exc}", err=True)
        raise typer.Exit(1) from None
    bus.say_lag = lambda text: typer.echo(f"warning: {text}", err=True)  # at most every 10 s (sim/core.py)
    timing = "wire timing on" if bus.wire_timing else "no wire timing"
    print(f"{len(bus.controllers)} controller(s), {timing}:")
    for line in describe(bus):
        print(f"  {line}")
    for where in ready:
        print(f"ready: {where}")
    sys.stdout.flush()
    background_ready()  # --background: the parent returns now
    while not stop.wait(0.5):
        pass
    for s in servers:
        s.stop()
    bus.close()
    if bus.fell_behind:
        print(f"fell behind real time {bus.fell_behind} time(s), worst {bus.worst_lag * 1000:.0f} ms")
    print("stopped")
    sys.stdout.flush()


def main() -> None:
    app = typer.Typer(add_completion=False, pretty_exceptions_enable=False)
    app.command()(sim)
    app()
