"""What every CLI command shares: global options, opening the bus, numbers, output, and errors.

Exit codes: 0 ok, 1 device or bus error (no answer, port missing, change not applied),
2 usage error (bad option, value out of range, unknown setting).
"""

from __future__ import annotations

import json
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NoReturn

import rich.table
import typer
from rich.console import Console
from rich.text import Text
from typer.core import TyperCommand

from ..errors import InputError, PortError
from .i18n import tr

if TYPE_CHECKING:  # the bus client (pyserial and all) loads when a command opens a bus, not for --help
    from ..drivers.sync import Bus
    from ..inputs import Rounded
    from ..procedures.motor import Motor

EXIT_OK, EXIT_DEVICE, EXIT_USAGE = 0, 1, 2
EXIT_TERMINATED = 143  # SIGTERM during a one-shot command (128 + 15, the shell's convention)
EXIT_INTERRUPTED = 130  # Ctrl+C (128 + SIGINT)

#: The longest error line we print; past it the message is cut (it stays one line).
MESSAGE_LIMIT = 400

# Colours only on a terminal (rich decides); stdout carries results, stderr carries messages.
out = Console(highlight=False)
err = Console(stderr=True, highlight=False)


class Terminated(BaseException):
    """SIGTERM arrived: unwind (closing the port, removing temp files) and exit cleanly.

    A BaseException so that no `except Exception` on the way swallows it."""


#: Ctrl+C and SIGTERM: what long-running commands (watch, sniff) treat as "stop now, report".
STOP = (KeyboardInterrupt, Terminated)


@contextmanager
def stop_flag() -> Iterator[threading.Event]:
    """For commands that loop until Ctrl+C or SIGTERM (watch): the signal only sets this flag and
    the loop ends at its next boundary (at most one reading plus the interval later).

    An exception raised by a signal handler lands wherever the main thread is: inside a
    transaction, in a lock or condition of the in-process simulator (a Condition.wait
    interrupted while re-taking its lock), in rich's redraw. We did not reproduce the watch that
    did not stop within 15 s under load (issue 24); this removes that whole class of causes:
    no exception is ever raised mid-reading."""
    flag = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in saved:
        signal.signal(sig, lambda *_: flag.set())
    try:
        yield flag
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


@dataclass
class Options:
    port: str | None = None
    baud: int = 9600
    ids: list[int] = field(default_factory=list)
    json: bool = False
    verbose: bool = False
    product: str = "mc"
    product_given: bool = False  # --product was given; else a command asks the controller its line
    rs485: bool = False  # RS485 direction control (docs/troubleshooting.md)
    rs485_invert: bool = False
    command: str = ""  # the command being run (an attached program is listed by it: nurimc clients)
    port_wait: float = 0.0  # global --port-wait: seconds to wait for a port that is about to appear


def one_line(message: object) -> str:
    text = " ".join(str(message).split())
    return text if len(text) <= MESSAGE_LIMIT else text[: MESSAGE_LIMIT - 3] + "..."


def say_error(message: object) -> None:
    """One line on stderr, `error: ...`, in the language in use (nurimc.cli.i18n)."""
    err.print(Text.assemble((tr("error:"), "bold red"), " ", one_line(tr(one_line(message)))), soft_wrap=True)


def note(message: str) -> None:
    """Something the person should know but that is not an error (e.g. a value the wire rounds)."""
    err.print(Text.assemble((tr("note:"), "yellow"), " ", one_line(tr(one_line(message)))), soft_wrap=True)


def say_line(text: str) -> None:
    """A long-running tool's line about its port (lost, back, not stopped: nurimc.transport.outage), in the
    language in use."""
    print(tr(text), file=sys.stderr, flush=True)


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    say_error(message)
    raise typer.Exit(code)


def options(ctx: typer.Context) -> Options:
    obj = ctx.find_root().obj
    return obj if isinstance(obj, Options) else Options()


# -- numbers a person types: every one goes through nurimc.inputs ----------------------------------


class Number:
    """A typer parser that checks a number with nurimc.inputs: finite, in range, unit in the message.

    With `step` (the wire's resolution), the value is rounded as the wire will round it and the
    rounding is reported on stderr (`note: --rpm 30.04 RPM -> 30 RPM`). With `whole`, fractions
    are refused (counts, IDs). A refusal is a usage error whose one line names the input."""

    def __init__(
        self, name: str, low: float, high: float, unit: str = "", *, step: float | None = None, whole: bool = False
    ) -> None:
        self.name, self.low, self.high, self.unit, self.step, self.whole = name, low, high, unit, step, whole

    @property
    def allowed(self) -> str:
        """For --help: `0.1..6553.3 RPM, steps of 0.1`."""
        from ..inputs import range_text, with_unit  # here: `nurimc --help` never needs nurimc.inputs

        steps = f", steps of {with_unit(self.step, self.unit)}" if self.step else ", whole" if self.whole else ""
        return range_text(self.low, self.high, self.unit) + steps

    def __call__(self, value: Any) -> Any:
        from ..inputs import integer, number, on_grid

        try:
            if self.whole:
                return integer(value, self.name, int(self.low), int(self.high), self.unit)
            if self.step is None:
                return number(value, self.name, self.low, self.high, self.unit)
            rounded = on_grid(value, self.name, self.step, self.low, self.high, self.unit)
        except InputError as error:
            raise InputBadParameter(str(error)) from None
        if rounded.changed and isinstance(value, str):  # defaults are on the grid; only typed text
            note(rounded.note(self.name, self.unit))
        return rounded.physical


# typer may ship its own copy of click: take click's error classes from typer, never from `import click`.
CLICK_ERROR: type[Exception] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")
USAGE_ERROR: type[Exception] = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")


class InputBadParameter(typer.BadParameter):
    """A bad value whose message already names the input, the range and the unit."""


def report(rounded: Rounded, name: str, unit: str) -> float:
    if rounded.changed:
        note(rounded.note(name, unit))
    return rounded.physical


def parse_ids(text: str | None, name: str = "--id") -> list[int]:
    """'1', '1,2,5', '0-3' -> IDs 0..254 (nurimc.inputs.id_list), each once, in order (usage error otherwise)."""
    from ..inputs import id_list

    try:
        return list(dict.fromkeys(id_list(text or "", name)))
    except InputError as error:
        fail(f"{error} (IDs like 1 or 1,2,5 or 0-3)")


def check_baud(rate: object, name: str = "--baud") -> int:
    from ..inputs import integer
    from ..protocol import BAUD_RATES  # here, as nurimc.inputs: `nurimc --help` needs neither table

    rates = ", ".join(map(str, BAUD_RATES))
    try:
        value = integer(rate, name, min(BAUD_RATES), max(BAUD_RATES), "bps")
    except InputError as error:
        fail(f"{error}, one of {rates}")
    if value not in BAUD_RATES:
        fail(f"{name}: {value} bps is not a rate these controllers support; use one of {rates}")
    return value


class FramePrinter:
    """-v: print every frame on the bus, decoded, to stderr. It only watches: printing never
    re-encodes (a broadcast ping to ID 255 is valid on the wire but not as a typed message)."""

    def __init__(self) -> None:
        from ..protocol import StreamParser  # here: the message classes load with -v, not for --help

        self.parsers = {"tx": StreamParser(), "rx": StreamParser()}

    def record(self, direction: str, data: bytes) -> None:
        for message in self.parsers[direction].feed(data):
            arrow = "->" if direction == "tx" else "<-"
            try:
                detail = str(message.physical())
            except Exception:  # a decoded frame that does not convert: show the raw fields instead
                detail = str(message.fields())
            err.print(Text(f"{arrow} {message.name} id={message.id} {detail}", style="dim"), soft_wrap=True)

    def close(self) -> None:
        pass


def open_bus(o: Options, reconnect: bool = False, attach: bool = True) -> Bus:
    """The bus of --port; reconnect: reopen it when it goes away (long-running tools: outage.py).
    When another nurimc program holds the port, the bus is attached to it (docs/service.md)."""
    from ..transport import RS485

    port = o.port or os.environ.get("NURIMC_PORT")
    if not port:
        fail("no port: give --port (e.g. /dev/ttyUSB0, socket://host:port, sim://?ids=1,2) or set NURIMC_PORT")
    rs485 = RS485(rts_level_for_tx=not o.rs485_invert) if o.rs485 else None
    tracer = FramePrinter() if o.verbose else None
    if attach:
        from .attach import attached_bus

        shared = attached_bus(port, o.baud, tracer, o.command)
        if shared is not None:
            return shared
    bus = _open_waiting(port, o, tracer=tracer, rs485=rs485, reconnect=reconnect)
    warning = getattr(bus.transport, "warning", None)
    if warning:
        err.print(Text.assemble((tr("warning:"), "yellow"), " ", one_line(tr(one_line(warning)))), soft_wrap=True)
    return bus


def _open_waiting(port: str, o: Options, **options: Any) -> Bus:
    """Bus.open, retried for up to --port-wait seconds while the port cannot be opened (a
    simulator's link or a USB adapter about to appear); then the last error, saying it waited."""
    from ..drivers.sync import Bus

    deadline = time.monotonic() + o.port_wait
    while True:
        try:
            return Bus.open(port, baudrate=o.baud, **options)
        except PortError as error:
            if o.port_wait <= 0:
                raise
            if time.monotonic() >= deadline:
                raise PortError(f"{error} (waited {o.port_wait:g} s, --port-wait)") from None
            time.sleep(0.1)


def motor_for(bus: Bus, o: Options, device_id: int, *, acts: bool = True) -> Motor:
    """The motor handle of a command in its product line: --product if given, else the line the
    controller answers as (nurimc.procedures.products). A command that acts is refused when the line cannot
    be told (the same bytes mean other commands in other lines); a read goes ahead as MC."""
    from ..procedures.collisions import shared_message, who_answers
    from ..procedures.products import detect_line

    if o.product_given:
        return bus.motor(device_id, o.product)
    if device_id not in bus.core.products:
        identified = bus.run(detect_line(bus.core, device_id))
        if identified.line == "unknown" and bus.run(who_answers(bus.core, device_id)) == "shared":
            # two new motors, both ID 0: each answer garbles the other's
            fail(shared_message(device_id, bus.baudrate) + ("; nothing was written" if acts else ""), EXIT_DEVICE)
        if identified.line == "unknown" and acts:
            fail(
                f"ID {device_id} at {bus.baudrate} bps answers none of the questions that tell product lines apart "
                "(or does not answer): give --product (mc, blmc-h, rsa, rsavw, sa, sm-cs, sm-readme)",
                EXIT_USAGE,
            )
    return bus.motor(device_id)


def one_id(o: Options) -> int:
    if len(o.ids) != 1:
        fail("this command needs exactly one controller: give --id N")
    return o.ids[0]


def emit(o: Options, data: Any, table: rich.table.Table | str | None = None) -> None:
    """One JSON document on stdout with --json; otherwise the table (or text) for people."""
    if o.json:
        sys.stdout.write(json.dumps(data, indent=2, default=str) + "\n")
    elif isinstance(table, str):
        out.print(tr(table), markup=False, soft_wrap=True)
    elif table is not None:
        show_table(table)


def show_table(table: rich.table.Table) -> None:
    """A table on stdout, its title a line of its own (as a table title it would wrap to the
    columns' width: a long path broken over two lines)."""
    if table.title:
        out.print(tr(str(table.title)), markup=False, soft_wrap=True)
        table.title = None
    out.print(table)


MARKED = re.compile(r"(\[[a-z ]+\])(.*)(\[/\])\Z", re.DOTALL)


def _cell(value: Any) -> Any:
    """A table cell in the language in use (`[red]no answer[/]` keeps its markup)."""
    if not isinstance(value, str):
        return value
    marked = MARKED.match(value)
    if marked:
        return marked.group(1) + tr(marked.group(2)) + marked.group(3)
    return tr(value)


class Table(rich.table.Table):
    """A rich table whose headers and cells are shown in the language in use."""

    def add_row(self, *renderables: Any, **options: Any) -> None:
        super().add_row(*(_cell(r) for r in renderables), **options)


def table(title: str | None, *columns: str) -> Table:
    t = Table(title=tr(title) if title else None, title_justify="left")
    for column in columns:
        t.add_column(tr(column))
    return t


_SIGNED_VALUE = re.compile(r"-[0-9.]")


class SignedValuesCommand(TyperCommand):
    """A command whose values may be negative numbers (`move -90`, `set ratio -5`): a word that
    starts with '-' and a digit or a point is a value, never a cluster of short options, so
    `set control -0h` is the value -0h (refused as a value), not -0 and -h (help, exit 0)."""

    def make_parser(self, ctx: Any) -> Any:  # typer's own click Context
        parser = super().make_parser(ctx)
        process_options = parser._process_opts

        def values_first(arg: str, state: Any) -> None:
            if _SIGNED_VALUE.match(arg):
                state.largs.append(arg)
                return
            process_options(arg, state)

        setattr(parser, "_process_opts", values_first)  # noqa: B010 - click has no hook for this
        return parser
