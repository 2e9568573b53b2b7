"""`nurimc demo`: the main job on a simulated bus — discover, configure, move, watch — and `bench`."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import typer
from rich.live import Live
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..drivers.sync import Bus
from ..procedures.discovery import Progress as ScanProgress
from ..procedures.discovery import discover
from ..sim import SimBus
from ..transport import SerialTransport
from .common import EXIT_DEVICE, Number, fail, out, show_table, table
from .i18n import tr

DEMO_MOTORS = {1: 115200, 2: 115200, 3: 57600}  # ID -> rate: the demo does not know them in advance
TARGETS = {1: 90.0, 2: -180.0, 3: 360.0}
DEMO_SECONDS = Number("--seconds", 0, 3600, "s")


def demo(
    seconds: float = typer.Option(
        4.0, help=f"How long to watch the motors move ({DEMO_SECONDS.allowed}).", parser=DEMO_SECONDS
    ),
) -> None:
    """Simulated bus with three motors: discover them, configure them, move them, watch them.

    Example: nurimc demo
    """
    sim = SimBus(wire_timing=True)
    for device_id, rate in DEMO_MOTORS.items():
        sim.add_controller(id=device_id, baud=rate)
    bus = Bus(SerialTransport(sim.open_serial(baudrate=9600), "sim://", latency=0.001))
    intro = tr("a simulated RS485 bus with 3 controllers at rates the host does not know.")
    out.print(f"[bold]nurimc demo[/]: {intro}")
    start = time.monotonic()
    columns = (TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    with Progress(*columns, console=out, transient=True) as bar:
        task = bar.add_task(tr("scanning"), total=18)

        def show(event: object) -> None:
            if isinstance(event, ScanProgress):
                bar.update(task, completed=event.rate_index + 1, description=tr(f"scanning {event.rate:>7} bps"))

        found = bus.run(discover(bus.core), on_note=show)
    found_table = table(
        f"discovery: {len(found)} controllers in {time.monotonic() - start:.1f} s (the vendor's tool: 20-30 minutes)",
        "ID",
        "baud",
        "firmware",
    )
    for f in found:
        found_table.add_row(str(f.id), str(f.baudrate), str(f.firmware))
    show_table(found_table)

    motors = []
    for f in found:
        bus.baudrate = f.baudrate
        motor = bus.motor(f.id)
        motor.set("resolution", 1024)  # a 1024-pulse encoder; written and read back
        motors.append((f.baudrate, motor))
        motor.move_to(TARGETS.get(f.id, 45.0), rpm=120)
        out.print(tr(f"ID {f.id}: resolution set to 1024 (verified), moving to {TARGETS.get(f.id, 45.0)}° at 120 RPM"))

    def render() -> Table:
        rows = table("live state", "ID", "target °", "position °", "speed RPM", "current A")
        for rate, motor in motors:
            bus.baudrate = rate
            s = motor.read_state()
            rows.add_row(
                str(motor.id),
                f"{TARGETS.get(motor.id, 45.0):.1f}",
                f"{s.position:8.2f}",
                f"{s.speed:6.1f}",
                f"{s.current:4.1f}",
            )
        return rows

    with Live(render(), console=out, auto_refresh=False) as live:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            time.sleep(0.1)
            live.update(render(), refresh=True)
    for rate, motor in motors:
        bus.baudrate = rate
        motor.release()
    out.print()
    stats = ", ".join(f"{name.replace('_', ' ')} {count}" for name, count in bus.stats.as_dict().items())
    out.print(tr(f"released all motors. Bus statistics: {stats}"), markup=False)
    me = invoked_as()
    # soft_wrap: a command is never broken over two lines (it would not work as printed)
    out.print(
        tr(f"Next, a simulator that keeps running (Ctrl+C ends it): [bold]{me} sim --link /tmp/nurimc0 --ids 1,2[/]"),
        soft_wrap=True,
    )
    then = tr(f"and, in another terminal from this folder: [bold]{me} --port /tmp/nurimc0 --id 1 status[/]")
    out.print(then, soft_wrap=True)
    bus.close()
    sim.close()


def invoked_as() -> str:
    """How to type this program again from here: `nurimc` if that is on PATH and is this one,
    else its path (`make demo` runs .venv/bin/nurimc, which is not on PATH)."""
    exe = Path(sys.argv[0])
    found = shutil.which("nurimc")
    if found and exe.exists() and Path(found).resolve() == exe.resolve():
        return "nurimc"
    if not exe.exists():
        return "nurimc"
    relative = os.path.relpath(exe)
    path = relative if len(relative) < len(str(exe.absolute())) else str(exe.absolute())
    return path if "/" in path else f"./{path}"


def bench(
    quick: bool = typer.Option(False, help="Short runs (never recorded)."),
    record: bool = typer.Option(False, help="Write the figures to benchmarks/results/ (full runs only)."),
) -> None:
    """Run the benchmarks (from a source checkout); record their results only with --record.

    Example: nurimc bench --record
    """
    root = Path(__file__).resolve().parents[4]
    scripts = sorted((root / "benchmarks").glob("*.py"))
    if not scripts:
        fail("the benchmarks live in the source tree (benchmarks/); run from a clone")
    if quick and record:
        fail("bench: --quick runs are too short to record; drop --quick to record")
    with tempfile.TemporaryDirectory(prefix="nurimc-bench-") as scratch:
        for script in scripts:
            out.print(f"[bold]{script.name}[/]")
            # Each script writes next to itself (results/); unless recording, it runs from a scratch copy.
            where = script if record else Path(shutil.copy(script, scratch))
            (where.parent / "results").mkdir(exist_ok=True)
            done = subprocess.run([sys.executable, str(where), *(["--quick"] if quick else [])], check=False)
            if done.returncode != 0:
                fail(f"bench: {script.name} failed (exit {done.returncode})", EXIT_DEVICE)
    out.print("recorded in benchmarks/results/" if record else "nothing recorded (add --record to keep the figures)")


def register(app: typer.Typer) -> None:
    app.command()(demo)
    app.command()(bench)
