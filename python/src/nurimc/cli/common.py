"""What every CLI command shares: global options, opening the bus, output, and errors.

Exit codes: 0 ok, 1 device or bus error (no answer, port missing, change not applied),
2 usage error (bad option, value out of range, unknown setting).
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass, field
from typing import Any, NoReturn

import typer
from rich.console import Console
from rich.table import Table

from ..client.sync import Bus
from ..protocol import BAUD_RATES, StreamParser

EXIT_OK, EXIT_DEVICE, EXIT_USAGE = 0, 1, 2

# Colours only on a terminal (rich decides); stdout carries results, stderr carries messages.
out = Console(highlight=False)
err = Console(stderr=True, highlight=False)


@dataclass
class Options:
    port: str | None = None
    baud: int = 9600
    ids: list[int] = field(default_factory=list)
    json: bool = False
    verbose: bool = False
    product: str = "mc"


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    err.print(f"[bold red]error:[/] {message}", soft_wrap=True)
    raise typer.Exit(code)


def options(ctx: typer.Context) -> Options:
    obj = ctx.find_root().obj
    return obj if isinstance(obj, Options) else Options()


def parse_ids(text: str | None) -> list[int]:
    """'1', '1,2,5', '0-3' -> IDs (usage error otherwise)."""
    if not text:
        return []
    ids: list[int] = []
    for part in text.split(","):
        try:
            if "-" in part.strip()[1:]:
                low, high = part.split("-", 1)
                ids += range(int(low), int(high) + 1)
            else:
                ids.append(int(part))
        except ValueError:
            fail(f"--id {text!r}: give IDs like 1 or 1,2,5 or 0-3")
    for i in ids:
        if not 0 <= i <= 254:
            fail(f"--id {i}: IDs are 0..254")
    return ids


def check_baud(rate: int) -> int:
    if rate not in BAUD_RATES:
        fail(f"--baud {rate}: not a rate these controllers support; use one of {', '.join(map(str, BAUD_RATES))}")
    return rate


class FramePrinter:
    """-v: print every frame on the bus, decoded, to stderr."""

    def __init__(self) -> None:
        self.parsers = {"tx": StreamParser(), "rx": StreamParser()}

    def record(self, direction: str, data: bytes) -> None:
        for message in self.parsers[direction].feed(data):
            arrow = "->" if direction == "tx" else "<-"
            line = f"{arrow} {message.encode().hex(' ')}  {message.name} id={message.id} {message.physical()}"
            err.print(f"[dim]{line}[/]")

    def close(self) -> None:
        pass


def open_bus(o: Options) -> Bus:
    port = o.port or os.environ.get("NURIMC_PORT")
    if not port:
        fail("no port: give --port (e.g. /dev/ttyUSB0, socket://host:port, sim://?ids=1) or set NURIMC_PORT")
    bus = Bus.open(port, baudrate=o.baud, tracer=FramePrinter() if o.verbose else None)
    warning = getattr(bus.transport, "warning", None)
    if warning:
        err.print(f"[yellow]warning:[/] {warning}", soft_wrap=True)
    return bus


def one_id(o: Options) -> int:
    if len(o.ids) != 1:
        fail("this command needs exactly one controller: give --id N")
    return o.ids[0]


def emit(o: Options, data: Any, table: Table | str | None = None) -> None:
    """One JSON document on stdout with --json; otherwise the table (or text) for people."""
    if o.json:
        sys.stdout.write(json.dumps(data, indent=2, default=str) + "\n")
    elif table is not None:
        out.print(table)


def table(title: str | None, *columns: str) -> Table:
    t = Table(title=title, title_justify="left")
    for column in columns:
        t.add_column(column)
    return t
