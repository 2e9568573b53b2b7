"""`nurimc`: the command-line entry point. Each command lives in its own module."""

from __future__ import annotations

import typer

from .. import __version__

app = typer.Typer(
    name="nurimc",
    help="Toolkit for Nurirobot MC and BLMC-H motor controllers on RS485.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


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
    from . import demo  # noqa: F401 - registers its command
    from . import sim_cmd  # noqa: F401


def main() -> None:
    _register()
    app()
