"""Command-line interface: ``roverimpact COMMAND ...``.

The CLI is thin: it parses, calls the library and prints. Every
:class:`~roverimpact.exceptions.RoverImpactError` (and unreadable/unwritable files)
becomes one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import click
import typer

# typer >= 0.17 vendors click as ``typer._click``; older releases raise click's own classes.
_ABORT = (click.exceptions.Abort, typer.Abort)
_USAGE = (click.exceptions.ClickException, typer.TyperException)

from ._app import app, err_console

# Command modules register themselves on ``app`` when imported.
from . import _partition  # noqa: F401  isort: skip
from . import _energy  # noqa: F401  isort: skip
from . import _draw  # noqa: F401  isort: skip
from . import _simulate  # noqa: F401  isort: skip
from . import _experiment  # noqa: F401  isort: skip
from . import _safety  # noqa: F401  isort: skip
from . import _contact  # noqa: F401  isort: skip
from . import _study  # noqa: F401  isort: skip
from . import _trust  # noqa: F401  isort: skip
from . import _optimize  # noqa: F401  isort: skip


def _print_error(exc: BaseException) -> None:
    """One red 'error:' prefix, then the message verbatim (no rich markup: brackets stay)."""
    err_console.print("[bold red]error:[/bold red] ", end="")
    err_console.print(str(exc), markup=False, highlight=False)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``roverimpact`` console script; returns the exit code."""
    from ..exceptions import RoverImpactError

    try:
        rv = app(args=argv, standalone_mode=False, prog_name="roverimpact")
    except _ABORT:
        err_console.print("[red]aborted[/red]")
        return 130
    except _USAGE as exc:  # usage errors (unknown option, bad value): exit 2
        if hasattr(exc, "show"):
            exc.show()
        else:  # pragma: no cover
            _print_error(exc)
        return int(getattr(exc, "exit_code", 2))
    except RoverImpactError as exc:
        _print_error(exc)
        return 2
    except (OSError, UnicodeDecodeError) as exc:
        _print_error(exc)
        return 2
    except KeyboardInterrupt:
        err_console.print("[red]interrupted[/red]")
        return 130
    return rv if isinstance(rv, int) else 0


__all__ = ["app", "main"]
