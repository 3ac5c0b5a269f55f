"""Command-line interface: ``roverimpact COMMAND ...``.

The CLI is thin: it parses, calls the library and prints. Every
:class:`~roverimpact.exceptions.RoverImpactError` (and unreadable/unwritable files)
becomes one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import _thread
import atexit
import contextlib
import functools
import os
import signal
import sys
import threading
import time

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


#: What stopped the command, noted by :func:`_signals_noted` (``"SIGINT"``, ``"SIGTERM"``)
_SEEN: list = []


def _stopped() -> tuple[str, int]:
    """The word and the exit code of a command stopped by a signal: ``terminated``, 143
    (128 + SIGTERM, as the shell reports a process it killed) after a SIGTERM, else
    ``interrupted``, 130."""
    return ("terminated", 143) if "SIGTERM" in _SEEN else ("interrupted", 130)


def _print_interrupted(word: str, exc: BaseException | None) -> None:
    """``interrupted`` (or ``aborted``), with what was kept and how to go on if known."""
    if word == "interrupted":
        word = _stopped()[0]
    detail = str(exc) if exc is not None else ""
    err_console.print(Text.assemble((word, "red"), (": " + detail) if detail else ""),
                      highlight=False)


#: Delay [s] before a KeyboardInterrupt that Python could not raise is delivered again
#: (:func:`_signals_noted`): long enough for the finalizer and the hook to have returned.
REDELIVER_S = 0.01


@contextlib.contextmanager
def _signals_noted(seen: list):
    """Note every Ctrl-C (SIGINT) and SIGTERM in ``seen``, and turn both into
    ``KeyboardInterrupt`` in this process.

    SIGTERM (``kill PID``, a job scheduler's time limit, ``timeout``) killed the command
    where it stood: a study's manifest said ``running`` for ever, and a command's staging
    folder (``.out.partial-*``) stayed beside its output folder. As an interruption, the
    command cleans up as after a Ctrl-C (the manifest says ``interrupted``, the staging
    folder goes) and exits with 143. A process forked from this one (a local Dask worker)
    inherits the handler; a SIGTERM ends it at once, as it did before.

    A Ctrl-C that arrives while numba's compiler is in a C callback is noted too: Python
    reports that KeyboardInterrupt as "Exception ignored" and numba then fails with "no
    compiled object yet" (a RuntimeError traceback at 10-16 s of a first run). Such a
    failure after a Ctrl-C is the interruption (exit 130). A KeyboardInterrupt that Python
    cannot raise where it lands (that C callback, a finalizer) is delivered again
    (``_thread.interrupt_main``), so that it stops the command at its next Python line."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    hook, pid = sys.unraisablehook, os.getpid()
    previous = {}

    def on_signal(signum, frame):
        if signum == signal.SIGTERM and os.getpid() != pid:  # a forked child: as before
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        seen.append(signal.Signals(signum).name)
        raise KeyboardInterrupt

    lock = threading.Lock()
    state = {"live": True, "fired": False}
    timers: list[threading.Timer] = []

    def again():
        with lock:
            if state["live"]:
                state["fired"] = True
                _thread.interrupt_main()

    def unraisable(u):
        if isinstance(u.exc_value, KeyboardInterrupt):
            seen.append("SIGINT")  # reported as the command's interruption below
            # raised where it cannot propagate (a finalizer: Dask's Future.__del__ as a
            # study drops a finished chunk's future; a C callback of numba's compiler), it
            # is delivered again, a moment later (here, in the hook, it would be lost too),
            # where the main thread then runs Python code: the command went on to its end
            # and exited 0 (a study given SIGINT after its first chunk)
            timer = threading.Timer(REDELIVER_S, again)
            timer.daemon = True
            timers.append(timer)
            timer.start()
        else:
            hook(u)

    # a signal ignored, or handled by someone else (an application calling main()), is
    # left as it is
    for sig, default in ((signal.SIGINT, signal.default_int_handler),
                         (signal.SIGTERM, signal.SIG_DFL)):
        if signal.getsignal(sig) is default:
            previous[sig] = signal.signal(sig, on_signal)
    if signal.SIGINT in previous:
        sys.unraisablehook = unraisable
    try:
        yield
    finally:
        try:  # nothing delivered again once the command has ended; one under way is taken
            with lock:
                state["live"] = False
            for timer in timers:
                timer.cancel()
            if state["fired"]:
                for _ in range(3):
                    time.sleep(0.001)
        except KeyboardInterrupt:
            pass
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        sys.unraisablehook = hook


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``roverimpact`` console script; returns the exit code."""
    _SEEN.clear()
    with _signals_noted(_SEEN):
        try:
            code = _main(argv)
        except KeyboardInterrupt:  # delivered again (_signals_noted) where _main had ended
            _print_interrupted("interrupted", None)
            return _stopped()[1]
        except Exception:
            if _SEEN:  # numba's compiler failing after a Ctrl-C it did not pass on
                _print_interrupted("interrupted", None)
                return _stopped()[1]
            raise
    return _stopped()[1] if code == 130 and _SEEN else code


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
