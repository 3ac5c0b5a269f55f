"""The typer application object, the consoles and the output helpers of the commands.

Everything a command prints goes through here, so that one place decides how text reads:

- the consoles print text as given (``markup=False``, ``emoji=False``): a unit in brackets,
  ``[kg]``, ``[m/s]``, never vanishes as rich markup, in a table header, a cell or a line;
- help strings (option help, command docstrings) are escaped once, when a command is
  registered, for typer's rich help (:class:`_Typer`);
- :func:`new_table` makes tables that wrap (fold) instead of truncating with "…";
- :func:`print_json` prints strict JSON (NaN and infinity are written as ``null``);
- :func:`print_csv` prints a table's rows as CSV;
- :func:`check_output` refuses an output folder or file that cannot be written, before
  any work.
"""

from __future__ import annotations

import csv
import functools
import inspect
import io
import json
import math
import os
from contextlib import contextmanager
from pathlib import Path

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table
from rich.text import Text

from .._version import __version__

console = Console(markup=False, emoji=False)
err_console = Console(stderr=True, soft_wrap=True, markup=False, emoji=False)


class CommandInterrupted(Exception):
    """Ctrl-C in a command, carried past typer (which would turn it into a silent exit 130)
    to :func:`roverimpact.cli.main`, which prints what was kept and exits with 130."""


def escape_help(text: str | None) -> str | None:
    """Help text for typer's rich mode: ``[kg]`` stays ``[kg]`` instead of being read as a
    style tag (rich drops unknown lower-case tags; ``[N]`` or ``[J]`` survive anyway)."""
    return None if text is None else escape(text)


def _escape_params(fn) -> None:
    for p in inspect.signature(fn).parameters.values():
        info = p.default
        if isinstance(info, typer.models.ParameterInfo) and info.help and not getattr(
                info, "_help_escaped", False):
            info.help = escape_help(info.help)
            info._help_escaped = True


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr (``warning: ...``), not Python's file:line form."""
    err_console.print(f"warning: {message}")


def _show_once():
    """:func:`_show_warning` for one command: each message once. A command may load the
    same model file several times (a study checks its scenarios, then runs them), and
    Python's own once-per-location registry is reset whenever a warnings filter changes."""
    shown: set[str] = set()

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        text = str(message)
        if text not in shown:
            shown.add(text)
            _show_warning(message, category, filename, lineno, file, line)

    return show


class _Typer(typer.Typer):
    """A Typer whose help keeps bracketed units and whose commands turn
    ``KeyboardInterrupt`` into :class:`CommandInterrupted`."""

    def __init__(self, *args, help: str | None = None, **kwargs):
        kwargs.setdefault("rich_markup_mode", "rich")
        super().__init__(*args, help=escape_help(help), **kwargs)

    def command(self, *args, help: str | None = None, **kwargs):
        def decorator(fn):
            _escape_params(fn)
            text = help if help is not None else inspect.getdoc(fn)
            register = super(_Typer, self).command(*args, help=escape_help(text), **kwargs)

            @functools.wraps(fn)
            def wrapper(*a, **kw):
                import warnings

                from .. import _kernels

                small = _kernels.small_work  # a command may declare its work small
                try:
                    with warnings.catch_warnings():
                        warnings.showwarning = _show_once()
                        return fn(*a, **kw)
                except KeyboardInterrupt as exc:
                    raise CommandInterrupted(str(exc)) from None
                finally:
                    _kernels.small_work = small

            register(wrapper)
            return fn

        return decorator


app = _Typer(
    name="roverimpact",
    help="Impact analysis of planetary rovers and other multibody systems.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
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


_escape_params(_root)


# ----------------------------------------------------------------------------------------
# tables, JSON, CSV
# ----------------------------------------------------------------------------------------


class _Table(Table):
    """A compact table for narrow terminals: right-aligned (number) columns whose cells are
    short (up to ``NUMBER_WIDTH`` characters) are as wide as their widest cell or header
    word, never folded; what the terminal lacks is taken from the other columns, whose
    cells wrap at words (or fold), never "…"."""

    NUMBER_WIDTH = 24

    def __rich_console__(self, console, options):
        for col in self.columns:
            if col.justify == "right" and col.width is None:
                cells = [len(str(c)) for c in col.cells]
                words = [len(w) for w in str(col.header).split()]
                if max(cells, default=0) <= self.NUMBER_WIDTH:
                    col.width = max([1, *cells, *words])
        yield from super().__rich_console__(console, options)


def compile_ahead(*later, now=(), small: bool = False, workers: bool = False) -> None:
    """On a fresh install, have the kernels a command needs compiled on two cores.

    ``later`` are compiled in a separate process, when numba's cache lacks them and the
    machine has a core to spare (see
    :func:`roverimpact._kernels._jit.compile_in_background`); the command loads them from
    the cache when it reaches them. ``now`` are compiled (or loaded) here, at once, while
    that process works. Split them so that neither process waits long for the other:
    ``roverimpact energy`` sends the row assembly (1.3 s of compile, needed first) and
    compiles the partition kernel (2.1 s) here (the other way round it waited 1.4 s);
    ``reproduce``, ``simulate``, ``sweep`` and ``traverse`` send Lemke's impact kernel
    (6-7 s, the longest) and compile the others here. A cold ``energy`` went from
    3.5-3.7 to 2.8-2.95 s with :func:`roverimpact.cli.run`'s end
    (benchmarks/bench_startup.py). A warm cache starts nothing and ``now`` only loads.

    ``small``: the command's work is small enough for the kernels' Python code, which
    runs while numba's cache lacks a kernel (:meth:`roverimpact._kernels._jit.Kernel.get`):
    the kernels of ``now`` whose items cost milliseconds in Python then go to the second
    process too, and the command works meanwhile instead of waiting for the compiler
    (unless forked Dask workers will do the work, ``workers``: they inherit what this
    process compiled, or ``ROVERIMPACT_KERNELS`` says otherwise). Those with a smaller
    ``python_budget`` (the contact-space integrators, tens of milliseconds an item) are
    still compiled here: a first full ``roverimpact reproduce`` otherwise waited for the
    Runge-Kutta kernel behind Lemke's in the second process (about 9 s more, in runs of
    ``benchmarks/bench_startup.py`` that may have overlapped an earlier run's compile).
    Large work compiles ``now`` here as before: with every kernel in the second process,
    a first ``roverimpact traverse examples/traverse_rocky.toml`` waited for them in turn
    and took 72-94 s against 41-44 s. ``small`` also declares the command's work small
    (:func:`roverimpact._kernels._jit.declare_small_work`, not for ``workers``): with a
    warm cache its first items run the Python code as well, where loading the first
    kernel would set up numba's compiler (a warm ``energy`` from 0.82 to 0.57 s,
    ``benchmarks/bench_startup.py``, 2026-11-30).
    """
    from .._kernels._jit import compile_in_background, declare_small_work, kernel_mode

    if small and not workers:
        declare_small_work()
        if now and kernel_mode() == "auto":
            later = (*later, *(k for k in now if k.python_budget is None))
            now = tuple(k for k in now if k.python_budget is not None)
    compile_in_background(*later)
    for k in now:
        k.get()


def compiles_here(workers, scheduler) -> bool:
    """Whether a command's kernels are best compiled in this process before its work
    (:func:`compile_ahead`): for a serial run, and for a local Dask cluster whose workers
    are forked from this process (they inherit what it compiled,
    :func:`roverimpact.studies.executors.worker_start_method`); not for a running
    scheduler's or spawned workers, which compile their own."""
    if scheduler is not None:
        return False
    if workers is None:
        return True
    from ..studies.executors import worker_start_method

    return worker_start_method() == "fork"


def new_table(title: str, *columns: str, left: tuple[str, ...] = (),
              right: tuple[str, ...] = ()) -> Table:
    """A table that stays readable in an 80-column terminal (:class:`_Table`).

    ``columns`` are the headers (printed as given: units in brackets stay); the first
    column (unless named in ``right``) and those named in ``left`` are left-aligned text,
    the others right-aligned numbers. A table narrower than its title widens to it (up to
    the terminal's width): rich wraps the title at the table's width, which broke
    ``contact``'s "v_n = 0.5 m/s" over two lines.
    """
    t = _Table(title=title, box=box.SIMPLE_HEAD, show_edge=False, padding=(0, 1),
               title_justify="left", caption_justify="left", min_width=len(title))
    for i, col in enumerate(columns):
        text = (i == 0 and col not in right) or col in left
        t.add_column(col, justify="left" if text else "right", overflow="fold")
    return t


def bold(text) -> Text:
    """``text`` in bold (the consoles read no markup)."""
    return Text(str(text), style="bold")


def print_paths(label: str, *paths, bold_path: bool = False) -> None:
    """``label: path[, path ...]`` on stdout, the paths never broken: rich would wrap a
    long path at the terminal's width in the middle of a name ("res" / "ults.parquet"),
    and a path copied from two lines does not exist. The line is left to the terminal's
    own soft wrap (as in a pipe, where it stays one line)."""
    text = Text(f"{label}: ")
    for i, p in enumerate(paths):
        if i:
            text.append(", ")
        text.append(str(p), style="bold" if bold_path else "")
    console.print(text, soft_wrap=True, highlight=False)


def jsonable(obj):
    """``obj`` with numpy scalars/arrays, paths and tuples made JSON types; NaN and
    infinity become ``None`` (JSON ``null``: not available, or unbounded)."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def json_text(obj) -> str:
    """Strict JSON of ``obj`` (:func:`jsonable`; never ``NaN`` or ``Infinity``)."""
    return json.dumps(jsonable(obj), indent=2, allow_nan=False)


def print_json(obj) -> None:
    """Print ``obj`` as strict JSON on stdout (no wrapping, no colour)."""
    console.out(json_text(obj), highlight=False)


def one_format(as_json: bool, as_csv: bool) -> None:
    """``--json`` and ``--csv`` are two ways to print the same table: one of them."""
    if as_json and as_csv:
        raise typer.BadParameter("give --json or --csv, not both")


def print_csv(header: list[str], rows) -> None:
    """Print ``rows`` (sequences of numbers and strings) as CSV on stdout, numbers at full
    precision; NaN is an empty field."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow(["" if x is None else x for x in jsonable(list(r))])
    console.out(buf.getvalue().rstrip("\n"), highlight=False)


# ----------------------------------------------------------------------------------------
# outputs
# ----------------------------------------------------------------------------------------


def check_output(path: Path, *, folder: bool, option: str = "-o",
                 suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse an output that cannot be written, before any work (see
    :func:`roverimpact._io.check_writable`); ``suffixes``: the file types accepted."""
    from .._io import check_writable

    return check_writable(path, folder=folder, option=option, suffixes=suffixes)


@contextmanager
def compile_notice(kernel, console=None, *, pid=None):
    """Around a kernel's first compile on this machine (a fresh install or an upgrade, when
    numba's cache cannot serve it; :data:`roverimpact._kernels.compile_notice`): a
    transient line on stderr saying what compiles, so that a first run of half a minute
    does not look hung. On a terminal only: pipes and logs get nothing; with ``pid``, in
    that process only (not in the Dask workers it forks, whose lines would cross the
    progress bar)."""
    console = err_console if console is None else console
    if not console.is_terminal or (pid is not None and os.getpid() != pid):
        yield
        return
    with console.status(f"compiling {kernel.__name__}, first run on this machine only"):
        yield


@contextmanager
def progress_bar(label: str, unit: str = "cases"):
    """A rich progress bar with ETA, shown from the first report on (so that a study
    rejected before any work prints only its error); yields ``progress(done, total)``.

    Drawn on stderr, by the console that prints the command's warnings and notes
    (:func:`_show_warning`), which rich then writes above the bar: printed by another
    console, a warning landed at the end of the bar's line on a terminal. stdout keeps
    the results (tables, JSON). Not drawn where stderr is not a terminal (a log, a pipe):
    there rich would write only the bar's last state, once, before the command's own
    last lines (an error that is one line would be two)."""
    bar = Progress(
        TextColumn("{task.description}", style="bold", markup=False), BarColumn(),
        MofNCompleteColumn(), TextColumn(unit, markup=False), TimeElapsedColumn(),
        TextColumn("ETA"), TimeRemainingColumn(),
        console=err_console, transient=False, disable=not err_console.is_terminal,
    )
    task = bar.add_task(label, total=None)
    started = False

    def update(done: int, total: int) -> None:
        nonlocal started
        if not started:
            bar.start()
            started = True
        bar.update(task, completed=done, total=total)

    try:
        yield update
    finally:
        if started:
            bar.stop()
