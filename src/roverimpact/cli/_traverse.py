"""``roverimpact traverse | traverse-report``: risk map and speed limits along a path.

Thin: parses, calls :mod:`roverimpact.traverse` and :mod:`roverimpact.report.traverse`,
prints.
"""

from __future__ import annotations

from pathlib import Path

import typer

from .._io import staged_folder
from ._app import (
    app,
    check_output,
    compile_ahead,
    compiles_here,
    console,
    err_console,
    new_table,
    print_json,
    print_paths,
    progress_bar,
)


def _f(x, fmt="{:.4g}") -> str:
    """A summary cell: "n/a" for NaN, "no limit" for an infinite speed limit (a path
    without impacts and without ``drive.v_max``)."""
    from ..report.traverse import NO_LIMIT

    return "n/a" if x != x else (NO_LIMIT if x == float("inf") else fmt.format(x))


#: The summary's columns left out first, in this order, where the terminal is too narrow
#: for all of them (the path, its largest peak force and its lowest limit always stay)
DROP_FIRST = ("stations", "failed poses", "length [m]", "at s [m]", "max F_pred [N]",
              "impacts", "max T_c^- [J]")


def _min_widths(cols, cells) -> dict:
    """Each summary column's least width: a number's widest cell (or header word: headers
    wrap at words), the path's name up to 10 characters (longer names fold)."""
    out = {}
    for i, c in enumerate(cols):
        longest = max((len(x) for x in cells[c]), default=1)
        word = max((len(w) for w in str(c).split()), default=1)
        out[c] = min(max(longest, word), 10) if i == 0 else max(longest, word)
    return out


def _print_summary(table, out=None) -> None:
    """The summary table on ``out`` (default the console). A number is never split: every
    number column is at least as wide as its widest cell; where the terminal is narrower
    than that, the columns of :data:`DROP_FIRST` are left out in turn, and the caption says
    which."""
    out = console if out is None else out
    cols = list(table.columns)
    cells = {c: [str(v) if isinstance(v, str) or table[c].dtype.kind in "iu"
                 else _f(float(v)) for v in table[c]] for c in cols}
    least = _min_widths(cols, cells)
    shown = list(cols)
    left: list[str] = []
    # one space of padding either side of each column, one between columns (new_table)
    while sum(least[c] for c in shown) + 3 * len(shown) - 1 > out.width:
        more = [c for c in DROP_FIRST if c in shown]
        if not more:
            break
        shown.remove(more[0])
        left.append(more[0])
    tab = new_table("Traverse: impacts and speed limits", *shown)
    for col, c in zip(tab.columns, shown, strict=True):
        col.min_width = least[c]
    for row in zip(*(cells[c] for c in shown), strict=True):
        tab.add_row(*row)
    if left:
        tab.caption = (f"left out at {out.width} columns: {', '.join(left)} (--json prints "
                       "every column)")
    out.print(tab)


def _compile_plan(config: Path, workers, scheduler) -> tuple:
    """On a fresh install, for a traverse run in this process: Lemke's impact kernel (6 s
    of compile) and the stiff Runge-Kutta pair (4.6 s) go to a second process, and the
    kernels returned (the lane-parallel partition, 8.6 s with the one-item kernel it
    requires, the effective masses of single rows and the Runge-Kutta kernel) are
    compiled here before the work
    (``compile_ahead``): a first ``roverimpact traverse examples/traverse_rocky.toml``
    took 31-33 s in one process, 22.4 s so (benchmarks/bench_startup.py --full). With
    local (forked) workers, the second process's kernels are then loaded here too, so
    that the workers inherit all of them. The file is read first, so a bad one fails
    before any compile."""
    from .._kernels.lanes_jit import LANES
    from .._kernels.lemke import impact_kernel
    from .._kernels.masses import masses_kernel
    from .._kernels.reduced import rk4_peaks, stiff_peaks
    from ..traverse.schema import load_traverse

    cfg = load_traverse(config)
    workers = workers if workers is not None else cfg.run.workers
    scheduler = scheduler if scheduler is not None else cfg.run.scheduler
    if not compiles_here(workers, scheduler):
        return ()
    forces = cfg.limits.F_allow is not None and cfg.limits.model == "weight"
    later = (impact_kernel, *((stiff_peaks,) if forces else ()))
    compile_ahead(*later)
    here = (LANES, masses_kernel, *((rk4_peaks,) if forces else ()))
    # forked workers do all the work: have every kernel loaded here before they fork
    return here if workers is None else (*here, *later)


#: What a traverse run writes: a folder holding these and manifest.json + traverse.toml is
#: a previous run, replaced by the next one
TRAVERSE_FILES = ("poses.parquet", "wheels.parquet", "segments.parquet", "poses.csv",
                  "wheels.csv", "segments.csv", "traverse.toml", "manifest.json",
                  "map.png", "map.svg", "map-*.png", "map-*.svg", "speed.png", "speed.svg",
                  "speed-*.png", "speed-*.svg", "report.html")


@app.command("traverse")
def traverse_cmd(
    config: Path = typer.Argument(..., help="Traverse file (TOML): terrain, path(s), rover, "
                                  "reference speed, allowable T_c^- or peak force."),
    out: Path = typer.Option(Path("traverse-results"), "-o", "--out", help="Output folder."),
    workers: int = typer.Option(None, "--workers", min=1,
                                help="Local Dask cluster of N processes."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler tcp://HOST:PORT."),
    csv: bool = typer.Option(False, "--csv", help="Also write the tables as CSV."),
    report: bool = typer.Option(True, "--report/--no-report",
                                help="Draw the map, the speed profile and report.html."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON (the "
                                 "progress bar goes to stderr)."),
) -> None:
    """Along each path: every wheel's next impact, T_c^-, predicted peak force, speed limit.

    The rover is placed at every station; T_c^- is at the reference speed. Writes
    poses.parquet (one row per station), wheels.parquet (per station and wheel),
    segments.parquet, map.png, speed.png and report.html in the output folder.
    """
    from ..report.traverse import summary, traverse_report
    from ..traverse.run import run_traverse

    now = _compile_plan(config, workers, scheduler)
    check_output(out, folder=True)
    with staged_folder(out, TRAVERSE_FILES, ("manifest.json", "traverse.toml"),
                       "traverse") as work:
        with progress_bar(config.stem, unit="stations") as update:
            # compiled once the inputs are checked: a bad path is refused at once
            res = run_traverse(config, work, workers=workers, scheduler=scheduler, csv=csv,
                               progress=update,
                               note=lambda text: err_console.print(f"note: {text}"),
                               prepare=lambda: compile_ahead(
                                   now=now, workers=workers is not None))
        path = (traverse_report(work, config=res.config, shown_as=out) if report
                else None)
    path = out / Path(path).name if path is not None else None
    res.files = {k: out / Path(p).name for k, p in res.files.items()}
    table = summary(res.poses, res.wheels, res.config)
    if as_json:
        print_json({"summary": table.to_dict(orient="records"), "elapsed_s": res.elapsed,
                    "timings": res.timings, "files": res.files, "report": path})
        return
    console.print(f"{len(res.poses)} stations on {table.shape[0]} path(s) in "
                  f"{res.elapsed:.1f} s")
    _print_summary(table)
    if path is not None:
        print_paths("report", path, bold_path=True)
    for role, p in res.files.items():
        print_paths(role, p)


@app.command("traverse-report")
def traverse_report_cmd(
    folder: Path = typer.Argument(..., help="An output folder of `roverimpact traverse`."),
) -> None:
    """Redraw the map, the speed profile and report.html from saved traverse tables."""
    from ..report.traverse import traverse_report

    print_paths("report", traverse_report(folder), bold_path=True)
