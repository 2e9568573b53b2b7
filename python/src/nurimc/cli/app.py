"""`nurimc`: the command-line entry point.

Each family of commands lives in its own module, which exposes `register(app)` and never
imports this one: the modules are listed once, in COMMAND_MODULES (a new one is one line
there), and nothing imports back.

Start-up (docs/performance.md): a command's module is imported only when that command runs.
`nurimc --help` lists the commands from command_index.py (each command's module, name and help,
written by `python scripts/cli_index.py`; tests/cli/test_startup.py fails when it is stale), so
it imports none of them; a module missing from the index is simply imported at start (slower,
never wrong). `app` (what scripts and tests read) is the whole tree, every module registered.
"""

from __future__ import annotations

import contextlib
import functools
import gettext
import signal
import sys
import traceback
from importlib import import_module
from types import FrameType
from typing import Any

import typer
import typer.core
import typer.main

from .. import __version__
from ..errors import NurimcError
from .command_index import COMMAND_INDEX
from .common import (
    CLICK_ERROR,
    EXIT_DEVICE,
    EXIT_OK,
    EXIT_TERMINATED,
    EXIT_USAGE,
    USAGE_ERROR,
    InputBadParameter,
    Number,
    Options,
    Terminated,
    check_baud,
    err,
    parse_ids,
    say_error,
)
from .i18n import DOMAIN, LOCALE_DIR, activated, tr, translate_help
from .i18n import _ as tr_help

#: --port-wait's range (seconds)
PORT_WAIT = Number("--port-wait", 0, 3600, "s")

#: Every module of commands (in nurimc.cli), in the order `nurimc --help` lists them.
COMMAND_MODULES = (
    "inspect",
    "motion",
    "settings_cmd",
    "tune_cmd",
    "frames",
    "demo",
    "sim_cmd",
    "dashboard_cmd",
    "ros2_cmd",
    "record_cmd",
    "service_cmd",
    "recording_cmd",
    "zero_cmd",
)

#: Commands that run until stopped: SIGTERM is their normal end (exit 0), not an interruption.
LONG_RUNNING = frozenset({"watch", "sniff", "dashboard", "sim", "ros2", "record", "serve"})
_invoked = [""]  # the command being run (set once the global options are parsed)


class LazyGroup(typer.core.TyperGroup):
    """The root command: each command module is imported when one of its commands is looked up
    to run; the help lists the not-yet-loaded commands from the index."""

    def list_commands(self, ctx: Any) -> list[str]:
        names = [name for module in COMMAND_MODULES for name in _index_names(module)]
        return list(dict.fromkeys([*names, *self.commands]))

    def get_command(self, ctx: Any, cmd_name: str) -> Any:
        if cmd_name not in self.commands:
            module = next((m for m in COMMAND_MODULES if cmd_name in _index_names(m)), None)
            for name in [module] if module is not None else COMMAND_MODULES:  # not in the index: every one
                self._load(name)
        return self.commands.get(cmd_name)

    def _load(self, module: str) -> None:
        if module in self._loaded:
            return
        self._loaded.add(module)
        for name, command in module_commands(module).items():
            self.commands.setdefault(name, translate_help(command) if self._translated else command)

    def format_commands(self, ctx: Any, formatter: Any) -> None:
        listed = self.commands
        try:  # the help's list without importing a command's module: stand-ins from the index
            self.commands = {**self._stand_ins(), **listed}
            super().format_commands(ctx, formatter)
        finally:
            self.commands = listed

    def _stand_ins(self) -> dict[str, Any]:
        made = {}
        for module, entries in COMMAND_INDEX.items():
            if module in self._loaded or module not in COMMAND_MODULES:
                continue
            for name, text, short, hidden in entries:
                made[name] = typer.core.TyperCommand(
                    name, help=_help(text, self._translated), short_help=_help(short, self._translated), hidden=hidden
                )
        return made

    _loaded: set[str]
    _translated = False


def module_commands(module: str) -> dict[str, Any]:
    """The click commands a command module registers (importing it), by name, in its order."""
    tree = typer.Typer(rich_markup_mode=None, add_completion=False, pretty_exceptions_enable=False)
    tree.callback()(_nothing)  # always a group, whose commands are taken over
    import_module(f"{__package__}.{module}").register(tree)
    return dict(typer.main.get_command(tree).commands)  # type: ignore[attr-defined]


def command_index() -> dict[str, tuple[tuple[str, str | None, str | None, bool], ...]]:
    """What command_index.py holds, worked out by importing every command module."""
    return {
        module: tuple((name, c.help, c.short_help, bool(c.hidden)) for name, c in module_commands(module).items())
        for module in COMMAND_MODULES
    }


def _nothing() -> None:
    """A sub-tree's callback (never run: its commands run under the root)."""


def _help(text: str | None, translated: bool) -> str | None:
    return tr_help(text) if text and translated else text


def _index_names(module: str) -> list[str]:
    return [entry[0] for entry in COMMAND_INDEX.get(module, ())]


ROOT: dict[str, Any] = {
    "name": "nurimc",
    "help": "Toolkit for Nurirobot MC and BLMC-H motor controllers on RS485 (MC-RS485 V1.0.1).\n\n"
    "Example: nurimc --port /dev/ttyUSB0 --baud 115200 --id 1 status",
    "no_args_is_help": True,
    "pretty_exceptions_enable": False,
    "rich_markup_mode": None,
    "add_completion": False,
    "context_settings": {"help_option_names": ["-h", "--help"]},
}
#: what main() runs: the global options and the built-in commands; the rest come as looked up
root = typer.Typer(cls=LazyGroup, **ROOT)


def _print_version(shown: bool) -> None:
    if shown:
        typer.echo(__version__)
        raise typer.Exit(EXIT_OK)


def main_options(
    ctx: typer.Context,
    port: str = typer.Option(
        None, "--port", "-p", envvar="NURIMC_PORT", help="Serial device or pyserial URL (sim://, socket://)."
    ),
    baud: str = typer.Option("9600", "--baud", "-b", envvar="NURIMC_BAUD", help="Bus baud rate (one of the 18)."),
    ids: str = typer.Option(None, "--id", "-i", envvar="NURIMC_ID", help="Controller ID(s): 1 or 1,2,5 or 0-3."),
    json_output: bool = typer.Option(False, "--json", help="Machine-readable output: one JSON document on stdout."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Also print every frame sent and received (stderr)."),
    product: str = typer.Option(
        None,
        "--product",
        "--line",
        help="Product: mc, blmc-h, rsa, rsavw, sa, sm, sm-cs, sm-readme (default: the line the controller answers as). "
        "Also the table decode, encode, sniff and replay read frames with. --line: the same (for one release).",
    ),
    port_wait: str = typer.Option(
        "0",
        "--port-wait",
        envvar="NURIMC_PORT_WAIT",
        help="Wait up to this many seconds for the port to appear (a simulator or an adapter just started).",
    ),
    rs485: bool = typer.Option(
        False, "--rs485", envvar="NURIMC_RS485", help="Drive the RS485 direction with RTS (no auto-direction adapter)."
    ),
    rs485_invert: bool = typer.Option(
        False, "--rs485-invert", help="With --rs485: the opposite RTS level while sending."
    ),
    show_version: bool = typer.Option(
        False, "--version", is_eager=True, callback=lambda shown: _print_version(shown), help="Print the version."
    ),
) -> None:
    from ..protocol import PRODUCTS  # here: `nurimc --help` and `--version` never build the product table

    if product is not None and product not in PRODUCTS:
        raise InputBadParameter(f"--product: {product!r} is not a product; use one of {', '.join(PRODUCTS)}")
    ctx.obj = Options(port, check_baud(baud), parse_ids(ids), json_output, verbose, product or "mc")
    ctx.obj.product_given = product is not None
    ctx.obj.rs485 = rs485 or rs485_invert
    ctx.obj.rs485_invert = rs485_invert
    ctx.obj.command = ctx.invoked_subcommand or ""  # how an attached program is listed (nurimc clients)
    ctx.obj.port_wait = PORT_WAIT(port_wait)
    _invoked[:] = [ctx.invoked_subcommand or ""]


def conformance() -> None:
    """JSON-lines conformance program (what `conformance/run python` runs)."""
    from ..conformance import serve

    serve()


def version() -> None:
    """Print the version."""
    typer.echo(__version__)


root.callback()(main_options)
root.command()(conformance)
root.command()(version)
#: modules that are not in the index (added since it was written): imported at start
_UNINDEXED = [m for m in COMMAND_MODULES if m not in COMMAND_INDEX]


@functools.cache
def _built(catalog_file: str | None) -> Any:
    """The click command typer builds from `app`, built once per language (16 ms each time:
    the in-process tests call main() thousands of times), its help in that language. Command
    modules are imported as their commands are looked up (LazyGroup)."""
    command = typer.main.get_command(root)
    assert isinstance(command, LazyGroup)
    command._loaded = set()
    command._translated = bool(catalog_file)
    if catalog_file:
        translate_help(command)
    for module in _UNINDEXED:
        command._load(module)
    return command


@functools.cache
def _whole_app() -> typer.Typer:
    whole = typer.Typer(**ROOT)
    whole.callback()(main_options)
    for module in COMMAND_MODULES:
        import_module(f"{__package__}.{module}").register(whole)
    whole.command()(conformance)
    whole.command()(version)
    return whole


def __getattr__(name: str) -> Any:
    """`app` with every command (scripts/catalogs.py, tests): each module registered on first use."""
    if name == "app":
        return _whole_app()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _command() -> Any:
    return _built(gettext.find(DOMAIN, LOCALE_DIR))


def _usage_line(error: Exception) -> str:
    if isinstance(error, InputBadParameter):
        return error.message
    text = str(getattr(error, "format_message", error.__str__)())
    ctx = getattr(error, "ctx", None)
    if isinstance(error, USAGE_ERROR) and ctx is not None:
        return f"{text} (see: {ctx.command_path} --help)"
    return text


def _on_sigterm(signum: int, frame: FrameType | None) -> None:
    raise Terminated


def _os_error_text(error: OSError) -> str:
    if error.strerror and error.filename:
        return f"{error.filename}: {error.strerror}"
    return str(error.strerror or error)


def _report(error: Exception, verbose: bool) -> int:
    """Say what failed in one line; the exit code (docs/cli.md, Exit codes and errors).

    Errors of nurimc share one root, NurimcError, whose ValueError branch (InputError,
    ProtocolError: what was given) is a usage error and the rest a device error; a click
    error is about the command line; an OSError is the system's."""
    if isinstance(error, typer.Abort):
        say_error("aborted")
        return EXIT_DEVICE
    if isinstance(error, CLICK_ERROR):
        say_error(_usage_line(error))
        return EXIT_DEVICE if getattr(error, "exit_code", EXIT_USAGE) == EXIT_DEVICE else EXIT_USAGE
    if isinstance(error, NurimcError):
        say_error(error)
        return EXIT_USAGE if isinstance(error, ValueError) else EXIT_DEVICE
    if isinstance(error, BrokenPipeError):  # the reader went away (`nurimc status | head -1`): nothing left to tell
        sys.stdout = None  # nothing more is written to the closed pipe
        return EXIT_DEVICE
    if isinstance(error, OSError):
        say_error(_os_error_text(error))
        return EXIT_DEVICE
    if isinstance(error, RecursionError):
        say_error("input nested too deeply")
        return EXIT_USAGE
    if isinstance(error, ValueError):  # a library we call refused a value we passed on
        say_error(error)
        return EXIT_USAGE
    say_error(f"unexpected {type(error).__name__}: {error} (this is a bug; run with -v for the traceback)")
    if verbose:
        traceback.print_exception(error)
    return EXIT_DEVICE


#: Global flags (no value) that may also follow the command: `nurimc --id 1 status --json`.
TRAILING_FLAGS = frozenset({"--json", "-v", "--verbose"})


#: Global options that take a value (the token after them is that value, not the command).
VALUED_GLOBALS = frozenset({"--port", "-p", "--baud", "-b", "--id", "-i", "--product", "--line", "--port-wait"})
#: Commands with a -v of their own (`nurimc sim -v` logs frames): their flags stay where they are.
OWN_VERBOSE = frozenset({"sim"})


def global_flags_first(args: list[str]) -> list[str]:
    """Move the global flags found after the command (and before `--`) to the front, where the
    parser reads them; people write `status --json` and `scan -v` as often as the other order."""
    end = args.index("--") if "--" in args else len(args)
    at = 0
    while at < end and args[at].startswith("-"):  # skip the global options to find the command
        at += 2 if args[at] in VALUED_GLOBALS else 1
    if at >= end or args[at] in OWN_VERBOSE:
        return args
    rest = args[at:end]
    flags = [a for a in rest if a in TRAILING_FLAGS]
    if not flags:
        return args
    return [*flags, *args[:at], *[a for a in rest if a not in TRAILING_FLAGS], *args[end:]]


def main(args: list[str] | None = None) -> None:
    """Run the CLI: every failure is one line on stderr and an exit code, never a traceback
    (unless -v/--verbose asks for one, after that line)."""
    args = global_flags_first(list(sys.argv[1:] if args is None else args))
    if not args:
        args = ["--help"]  # `nurimc` alone: the normal help, on stdout, exit 0
    before = args[: args.index("--")] if "--" in args else args
    verbose = "-v" in before or "--verbose" in before
    _invoked[0] = ""
    previous = signal.getsignal(signal.SIGTERM)
    if previous is signal.SIG_DFL:
        signal.signal(signal.SIGTERM, _on_sigterm)
    code = EXIT_OK
    language = contextlib.ExitStack()  # click's own words in the language in use, for this call
    language.enter_context(activated())
    try:
        result = _command().main(args=args, prog_name="nurimc", standalone_mode=False)
        code = result if isinstance(result, int) else EXIT_OK
    except Terminated:
        if _invoked[0] in LONG_RUNNING:
            code = EXIT_OK
        else:
            say_error("terminated (SIGTERM) before the command finished")
            code = EXIT_TERMINATED
    except KeyboardInterrupt:
        err.print(tr("interrupted"))
        code = 130
    except Exception as error:
        from .placement import where_it_goes  # only when click refused an option (start-up stays lean)

        hint = (
            where_it_goes(getattr(error, "option_name", None), args) if type(error).__name__ == "NoSuchOption" else None
        )
        if hint:  # `nurimc status --id 1`: say where --id goes
            say_error(hint)
            code = EXIT_USAGE
        else:
            code = _report(error, verbose)
    finally:
        language.close()
        with contextlib.suppress(OSError, AttributeError):
            sys.stdout.flush()
        if previous is signal.SIG_DFL:
            signal.signal(signal.SIGTERM, previous)
    sys.exit(code)
