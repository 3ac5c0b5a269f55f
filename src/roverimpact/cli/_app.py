"""The typer application object and the consoles shared by the command modules."""

from __future__ import annotations

import typer
from rich.console import Console

from .._version import __version__

console = Console()
err_console = Console(stderr=True, soft_wrap=True)

app = typer.Typer(
    name="roverimpact",
    help="Impact analysis of planetary rovers and other multibody systems.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"roverimpact {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True,
        help="Print the version and exit.",
    ),
) -> None:
    """Impact analysis of planetary rovers and other multibody systems."""
