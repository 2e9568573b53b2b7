"""`nurimc`: the command-line entry point. Each family of commands lives in its own module."""

from __future__ import annotations

import sys

import typer

from .. import __version__
from ..errors import NurimcError
from ..protocol import ProtocolError
from .common import EXIT_DEVICE, EXIT_USAGE, Options, check_baud, err, parse_ids

app = typer.Typer(
    name="nurimc",
    help="Toolkit for Nurirobot MC and BLMC-H motor controllers on RS485 (MC-RS485 V1.0.1).\n\n"
    "Example: nurimc --port /dev/ttyUSB0 --baud 115200 --id 1 status",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


@app.callback()
def main_options(
    ctx: typer.Context,
    port: str = typer.Option(
        None, "--port", "-p", envvar="NURIMC_PORT", help="Serial device or pyserial URL (sim://, socket://)."
    ),
    baud: int = typer.Option(9600, "--baud", "-b", envvar="NURIMC_BAUD", help="Bus baud rate (one of the 18)."),
    ids: str = typer.Option(None, "--id", "-i", envvar="NURIMC_ID", help="Controller ID(s): 1 or 1,2,5 or 0-3."),
    json_output: bool = typer.Option(False, "--json", help="Machine-readable output: one JSON document on stdout."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log every frame sent and received (stderr)."),
    product: str = typer.Option("mc", "--product", help="Product profile: mc or blmc-h."),
) -> None:
    if product not in ("mc", "blmc-h"):
        raise typer.BadParameter("use mc or blmc-h", param_hint="--product")
    ctx.obj = Options(port, check_baud(baud), parse_ids(ids), json_output, verbose, product)


@app.command()
def conformance() -> None:
    """JSON-lines conformance program (what `conformance/run python` runs)."""
    from ..conformance import serve

    serve()


@app.command()
def version() -> None:
    """Print the version."""
    typer.echo(__version__)


def _register() -> None:
    from . import dashboard_cmd, demo, frames, inspect, motion, settings_cmd, sim_cmd  # noqa: F401 - each registers its commands


def main() -> None:
    """Run the CLI; turn library errors into one line and an exit code, never a traceback."""
    _register()
    try:
        app(standalone_mode=True)
    except NurimcError as error:
        err.print(f"[bold red]error:[/] {error}", soft_wrap=True)
        sys.exit(EXIT_DEVICE)
    except (ProtocolError, ValueError, KeyError) as error:
        text = error.args[0] if isinstance(error, KeyError) and error.args else error
        err.print(f"[bold red]error:[/] {text}", soft_wrap=True)
        sys.exit(EXIT_USAGE)
    except KeyboardInterrupt:
        err.print("interrupted")
        sys.exit(130)
