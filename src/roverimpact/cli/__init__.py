"""Command-line interface: ``roverimpact COMMAND ...``.

The CLI is thin: it parses, calls the library and prints. Every
:class:`~roverimpact.exceptions.RoverImpactError` (and unreadable/unwritable files)
becomes one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import click

from ._app import app, err_console

# Command modules register themselves on ``app`` when imported.
from . import _partition  # noqa: E402,F401  isort: skip


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``roverimpact`` console script; returns the exit code."""
    from ..exceptions import RoverImpactError

    try:
        rv = app(args=argv, standalone_mode=False, prog_name="roverimpact")
    except click.exceptions.Abort:
        err_console.print("[red]aborted[/red]")
        return 130
    except click.exceptions.ClickException as exc:  # usage errors: exit 2
        exc.show()
        return exc.exit_code
    except RoverImpactError as exc:
        err_console.print(f"[bold red]error:[/bold red] {exc}", highlight=False)
        return 2
    except (OSError, UnicodeDecodeError) as exc:
        err_console.print(f"[bold red]error:[/bold red] {exc}", highlight=False)
        return 2
    except KeyboardInterrupt:
        err_console.print("[red]interrupted[/red]")
        return 130
    return rv if isinstance(rv, int) else 0


__all__ = ["app", "main"]
