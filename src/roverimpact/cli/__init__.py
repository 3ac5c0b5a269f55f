"""Command-line interface: ``roverimpact COMMAND ...``.

The CLI is thin: it parses, calls the library and prints. Every
:class:`~roverimpact.exceptions.RoverImpactError` (and unreadable/unwritable files)
becomes one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import os
import signal
import sys
import threading

import typer
from rich.text import Text

# typer >= 0.28 carries its own click: every usage error derives from TyperException.
_ABORT = (typer.Abort,)
_USAGE = (typer.TyperException,)
try:  # `roverimpact` or `roverimpact safety` alone prints its help
    from typer._click.exceptions import NoArgsIsHelpError as _NO_ARGS
except ImportError:  # pragma: no cover - another typer
    _NO_ARGS = ()

from ._app import CommandInterrupted, app, err_console

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
from . import _traverse  # noqa: F401  isort: skip


def _print_error(exc: BaseException | str) -> None:
    """One line: a red 'error:' prefix, then the message verbatim (brackets stay)."""
    msg = " ".join(str(exc).split())  # one line, whatever the message holds
    err_console.print(Text.assemble(("error:", "bold red"), " ", msg), highlight=False)


def _usage_message(exc) -> str:
    """A usage error (unknown option, bad value) as one line, with where to find help."""
    ctx = getattr(exc, "ctx", None)
    hint = f" (see '{ctx.command_path} --help')" if ctx is not None else ""
    return exc.format_message() + hint


def _print_interrupted(word: str, exc: BaseException | None) -> None:
    """``interrupted`` (or ``aborted``), with what was kept and how to go on if known."""
    detail = str(exc) if exc is not None else ""
    err_console.print(Text.assemble((word, "red"), (": " + detail) if detail else ""),
                      highlight=False)


@contextlib.contextmanager
def _ctrl_c_noted(seen: list):
    """Note every Ctrl-C in ``seen``, including one that arrives while numba's compiler is
    in a C callback: Python reports that KeyboardInterrupt as "Exception ignored" and
    numba then fails with "no compiled object yet" (a RuntimeError traceback at 10-16 s of
    a first run). Such a failure after a Ctrl-C is the interruption (exit 130)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous, hook = signal.getsignal(signal.SIGINT), sys.unraisablehook
    if previous is not signal.default_int_handler:  # ignored, or someone else's handler
        yield
        return

    def on_sigint(signum, frame):
        seen.append(True)
        raise KeyboardInterrupt

    def unraisable(u):
        if isinstance(u.exc_value, KeyboardInterrupt):
            seen.append(True)  # reported as the command's interruption below
        else:
            hook(u)

    signal.signal(signal.SIGINT, on_sigint)
    sys.unraisablehook = unraisable
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        sys.unraisablehook = hook


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``roverimpact`` console script; returns the exit code."""
    seen: list = []
    with _ctrl_c_noted(seen):
        try:
            return _main(argv)
        except Exception:
            if seen:  # numba's compiler failing after a Ctrl-C it did not pass on
                _print_interrupted("interrupted", None)
                return 130
            raise


def _main(argv: list[str] | None) -> int:
    from .. import _kernels
    from ..exceptions import RoverImpactError
    from ._app import compile_notice

    # first compiles say what they compile (in this process, not in forked workers)
    _kernels.compile_notice = functools.partial(compile_notice, pid=os.getpid())
    try:
        rv = app(args=argv, standalone_mode=False, prog_name="roverimpact")
    except _ABORT as exc:  # click turns Ctrl-C into Abort; the interruption is its cause
        cause = exc.__cause__
        word = "interrupted" if isinstance(cause, KeyboardInterrupt) else "aborted"
        _print_interrupted(word, cause)
        return 130
    except _USAGE as exc:  # usage errors (unknown option, bad value): one line, exit 2
        if isinstance(exc, _NO_ARGS):  # `roverimpact` or a group alone: its help
            exc.show()
        elif hasattr(exc, "format_message"):
            _print_error(_usage_message(exc))
        else:  # pragma: no cover
            _print_error(exc)
        return int(getattr(exc, "exit_code", 2))
    except RoverImpactError as exc:
        _print_error(exc)
        return 2
    except (OSError, UnicodeDecodeError) as exc:
        if isinstance(exc, OSError) and exc.strerror and exc.filename:
            _print_error(f"{exc.filename}: {exc.strerror}")  # not "[Errno 30] ..."
        else:
            _print_error(exc)
        return 2
    except (KeyboardInterrupt, CommandInterrupted) as exc:
        _print_interrupted("interrupted", exc)
        return 130
    return rv if isinstance(rv, int) else 0


def run() -> None:
    """Entry point of the ``roverimpact`` console script: :func:`main`, then the process ends
    without the interpreter's teardown.

    Python's shutdown frees every module object one by one, about 0.3 s after a command
    that loaded numba's compiled kernels (warm ``roverimpact energy`` went from 0.86 to
    0.66-0.71 s with this end; benchmarks/bench_startup.py). The command's files are
    closed by then (the package writes through context managers and atomic replaces), so
    the end is: the exit handlers (``atexit``: logging, Dask, multiprocessing), the
    standard streams (Python's and C's) flushed, ``os._exit``. With another non-daemon
    thread still running (which Python would wait for) the process exits the usual way.
    """
    code = main()
    if any(t is not threading.main_thread() and not t.daemon and t.is_alive()
           for t in threading.enumerate()):
        sys.exit(code)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (`| head`): nothing left to say
            code = code or 1
    _flush_c_streams()  # what C/C++ code (Pinocchio's parsers) printed through stdio
    os._exit(code)


def _flush_c_streams() -> None:
    try:
        import ctypes

        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # pragma: no cover - no C library to ask
        pass


__all__ = ["app", "main", "run"]
