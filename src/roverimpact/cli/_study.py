"""``roverimpact sweep | report | reproduce``: run studies, regenerate reports, reproduce papers.

Thin: parses, calls :mod:`roverimpact.studies` / :mod:`roverimpact.report`, prints.
"""

from __future__ import annotations

import re
from pathlib import Path

import typer

from ._app import (
    app,
    compile_ahead,
    compiles_here,
    console,
    err_console,
    new_table,
    print_json,
    print_paths,
    progress_bar,
)

_STATS = (("Spearman", "spearman"), ("Kendall", "kendall"), ("Pearson", "pearson"),
          ("concordant", "concordant_fraction"))


def _f(x: float) -> str:
    return "n/a" if x != x else f"{x:.3f}"


def _label(s) -> str:
    """The paper figure of a built-in study ("DETC2014 Fig. 2"), else the folder's name."""
    from ..studies.builtin import BUILTIN_STUDIES

    fig = BUILTIN_STUDIES.get(s.folder.name)
    return re.sub(r"-\d+ ", " ", fig) if fig else s.folder.name


def _print_stats(sections) -> None:
    """One row per statistic and study: readable at 80 columns (labels wrap, never "…")."""
    tab = new_table("T_c^- vs simulated peak force F_max: rank agreement",
                    "study", "cases", "n", "excl.", "statistic", "value", "95% CI",
                    left=("statistic",))
    tab.caption = ("n: cases in the statistics. excl.: whole-window cases excluded (the "
                   "contact had not ended when the simulation stopped, so F_max is not an "
                   "impact peak). Kendall: tau-b; concordant: share of concordant pairs; "
                   "CI: percentile bootstrap.")
    for s in sections:
        a = s.agreement
        head = [_label(s), str(s.n_cases)]
        if a is None:
            tab.add_row(*head, "-", str(s.n_whole_window), "F_max n/a", "", "",
                        end_section=True)
            continue
        for i, (name, key) in enumerate(_STATS):
            e = getattr(a, key)
            first = [*head, str(a.n), str(s.n_whole_window)] if i == 0 else [""] * 4
            tab.add_row(*first, name, _f(e.value), f"[{_f(e.low)}, {_f(e.high)}]",
                        end_section=i == len(_STATS) - 1)
    console.print(tab)
    for s in sections:  # what the statistics leave out (failed simulations, too few cases)
        if s.note and s.manifest.get("simulate"):
            console.print(f"{_label(s)}: {s.note}", highlight=False)
    _print_indicators(sections)


#: Short headers of the indicator columns (80-column table).
_IND_HEAD = {"T_c_minus": "T_c^-", "v_n": "v_n", "T_n_total": "m_total v_n^2/2",
             "T_c_obstacle": "T_c^- obst. row"}


def _print_indicators(sections) -> None:
    """Spearman of T_c^- and of each baseline with every engine's F_max, and the summary
    statement of each (derived from the statistics, :mod:`roverimpact.studies.indicators`)."""
    rows = [(s, e) for s in sections for e in s.engines if e.comparison is not None]
    if not rows:
        return
    cols = [c for c in _IND_HEAD if any(e.comparison.result(c) for _, e in rows)]
    tab = new_table("Rank correlation rho of each indicator with F_max (T_c^- and the "
                    "baselines)", "study",
                    "engine", "n", *(_IND_HEAD[c] for c in cols), left=("engine",))
    tab.caption = ("Same cases for every indicator. const.: the same in every case (cannot "
                   "rank). T_c^- obst. row: T_c^- with the obstacle row only, 1/2 m_free "
                   "v_n^2. The report gives intervals and the paired differences.")
    lines = []
    for s, e in rows:
        c = e.comparison
        cells = []
        for col in cols:
            r = c.result(col)
            cells.append("-" if r is None else "const." if r.constant
                         else _f(r.agreement.spearman.value))
        tab.add_row(_label(s), e.label, str(c.n), *cells)
        short = [t for t in c.statements if t.startswith("In short: ")]
        if short:
            lines.append(f"{_label(s)}, {e.label}: {short[0].removeprefix('In short: ')}")
    console.print(tab)
    for ln in lines:
        console.print(ln, highlight=False)


def _stats_json(sections) -> list[dict]:
    out = []
    for s in sections:
        out.append({
            "study": s.name, "label": _label(s), "folder": s.folder, "cases": s.n_cases,
            "n": s.agreement.n if s.agreement is not None else 0,
            "n_whole_window": s.n_whole_window, "whole_window": "excluded",
            "agreement": s.agreement.as_dict() if s.agreement is not None else None,
            "engines": [e.as_dict() for e in s.engines],
            "note": s.note, "figures": dict(s.figures), "maps": dict(s.maps),
        })
    return out


#: Studies of at most this many cases run the kernels' Python code while numba's cache lacks
#: them (``compile_ahead(small=True)``); larger ones compile them here before the work.
SMALL_STUDY = 500


def _compile_plan(study: Path, workers, scheduler) -> tuple[tuple, bool]:
    """On a fresh install, for a study run in this process: Lemke's impact kernel (the
    active set; 6-7 s of compile) goes to a second process, and the kernels returned (the
    partition, and the Runge-Kutta kernel of the refined prediction when the study
    simulates) are compiled here before the work (``compile_ahead``): a first
    ``roverimpact sweep examples/study_rover2d_beta_h.toml`` took 13.7 s in one process,
    8.8 s so (benchmarks/bench_startup.py --full). The file is read first, so a bad one
    fails before any compile; the kernels returned are compiled once the options are
    checked (``run_study(prepare=...)``), in the second process too for a study of at most
    :data:`SMALL_STUDY` cases (returned: whether it is one), which runs their Python code
    meanwhile: 8.3 s instead of 20.3 s for that first sweep of 16 cases, 2026-11-29."""
    from .._kernels.lemke import impact_kernel
    from .._kernels.partition import partition_kernel
    from .._kernels.reduced import rk4_peaks
    from ..studies.config import load_study

    spec, _text = load_study(study)
    if not compiles_here(workers, scheduler):
        return (), False
    compile_ahead(impact_kernel)
    return ((partition_kernel, *((rk4_peaks,) if spec.simulate else ())),
            spec.n_cases() <= SMALL_STUDY)


@app.command("sweep")
def sweep_cmd(
    study: Path = typer.Argument(..., help="Study file (TOML): base scenario + grid/cases/random."),
    out: Path = typer.Option(Path("results"), "-o", "--out", help="Output folder."),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted run."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Discard results in the folder."),
    csv: bool = typer.Option(False, "--csv", help="Also write results.csv."),
    workers: int = typer.Option(None, "--workers", help="Local Dask cluster of N processes."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler tcp://HOST:PORT."),
    chunk_size: int = typer.Option(None, "--chunk-size", min=1, help="Cases per chunk."),
    report: bool = typer.Option(True, "--report/--no-report", help="Write figure + report.html."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary and the statistics "
                                 "as JSON (the progress bar goes to stderr)."),
    allow_failures: bool = typer.Option(False, "--allow-failures",
                                        help="Exit 0 even if some simulations failed or "
                                        "some cases could not be posed."),
    on_error: str = typer.Option("stop", "--on-error", help="A case that cannot be posed "
                                 "(parameters no model has): stop the study (the finished "
                                 "chunks are kept), or record it (its outputs missing, "
                                 "column error saying why) and go on."),
) -> int:
    """Run a study: every case's T_c^-, effective mass, predicted (and simulated) peak force.

    Exit code 1 if a simulation failed (the case's forces are NaN; see sim_error in the
    results) or, with --on-error record, a case could not be posed (see error), unless
    --allow-failures.
    """
    from ..studies.executors import check_on_error
    from ..studies.sweep import run_study

    check_on_error(on_error)
    now, small = _compile_plan(study, workers, scheduler)
    with progress_bar(study.stem) as update:
        res = run_study(study, out, resume=resume, overwrite=overwrite, csv=csv,
                        workers=workers, scheduler=scheduler, chunk_size=chunk_size,
                        progress=update, on_error=on_error,
                        note=lambda text: err_console.print(f"note: {text}"),
                        prepare=lambda: compile_ahead(now=now, small=small,
                                                      workers=workers is not None))
    path, sections = None, []
    if report:
        from ..exceptions import StudyInterrupted
        from ..report.html import build_report

        try:
            path, sections = build_report(res.out_dir)
        except KeyboardInterrupt:  # a bare "interrupted" said nothing of the results
            raise StudyInterrupted(
                f"interrupted while writing the report; the results are complete in "
                f"{res.out_dir}: `roverimpact report {res.out_dir}` writes it") from None
    failed = _failed_simulations(res.failures, res.n_cases, allow_failures)
    unposed = _not_posed(res, allow_failures)
    failed = max(failed, unposed[1])
    if as_json:
        print_json({"cases": res.n_cases, "computed": res.n_computed,
                    "reused": res.n_reused, "failed": len(res.failures),
                    "not_posed": unposed[0],
                    "elapsed_s": res.elapsed, "files": res.files,
                    "report": path, "studies": _stats_json(sections)})
        return failed
    console.print(
        f"{res.n_cases} cases ({res.n_computed} computed, {res.n_reused} reused) in "
        f"{res.elapsed:.1f} s"
    )
    if report:
        _print_stats(sections)
        print_paths("report", path, bold_path=True)
    for role, p in res.files.items():
        print_paths(role, p)
    return failed


def _failed_simulations(failures, n_cases: int, allowed: bool) -> int:
    """Say (on stderr) how many simulations failed and why (the first error); the exit
    code: 1 unless allowed."""
    if failures.empty:
        return 0
    err_console.print(f"{len(failures)} of {n_cases} simulations failed (case "
                      f"{int(failures['case'].iloc[0])}: {failures['sim_error'].iloc[0]}); "
                      "their forces are NaN in the results", style="yellow")
    return 0 if allowed else 1


def _not_posed(res, allowed: bool) -> tuple[int, int]:
    """Say (on stderr) how many cases of the study ``res`` could not be posed and why
    (the first error; the table is read by its error column only); how many, and the exit
    code: 1 unless allowed."""
    from ..studies.store import count_not_posed

    n, case, error = count_not_posed(res.files["results"])
    if not n:
        return 0, 0
    err_console.print(f"{n} of {res.n_cases} cases could not be posed (case {case}: "
                      f"{error}); their outputs are missing in the results, column error "
                      "says why", style="yellow")
    return n, 0 if allowed else 1


@app.command("report")
def report_cmd(
    results: Path = typer.Argument(..., help="A results folder (of sweep or reproduce)."),
    n_boot: int = typer.Option(1000, "--n-boot", min=0, help="Bootstrap resamples of the "
                               "intervals: 0 for none, else at least 100."),
    seed: int = typer.Option(0, "--seed", help="Bootstrap seed."),
    as_json: bool = typer.Option(False, "--json", help="Print the statistics as JSON."),
) -> None:
    """Regenerate the figures and the HTML report from saved results (no recomputation)."""
    from ..report.html import build_report, missing_studies_note

    path, sections = build_report(results, n_boot=n_boot, seed=seed)
    note = missing_studies_note(results)
    if note:
        err_console.print(f"note: {note}", highlight=False)
    if as_json:
        print_json({"report": path, "studies": _stats_json(sections)})
        return
    _print_stats(sections)
    for s in sections:
        print_paths("figure", s.figures.get("png"))
        if s.maps:
            print_paths("map", s.maps.get("png"))
    print_paths("report", path, bold_path=True)


@app.command("reproduce")
def reproduce_cmd(
    out: Path = typer.Option(None, "-o", "--out", help="Output folder (default "
                             "./roverimpact-results, with --quick ./roverimpact-results-quick)."),
    quick: bool = typer.Option(False, "--quick", help="Smoke run: 5 points per study."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Let --quick replace a full "
                                   "reproduction in the folder."),
    workers: int = typer.Option(None, "--workers", help="Local Dask cluster of N processes "
                                "for each study in turn (default: the studies side by side, "
                                "a process per core; 1: one after the other here)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler tcp://HOST:PORT."),
    n_boot: int = typer.Option(1000, "--n-boot", min=0, help="Bootstrap resamples of the "
                               "intervals: 0 for none, else at least 100."),
    as_json: bool = typer.Option(False, "--json", help="Print the statistics as JSON (the "
                                 "progress bar goes to stderr)."),
    allow_failures: bool = typer.Option(False, "--allow-failures",
                                        help="Exit 0 even if some simulations failed."),
) -> int:
    """Reproduce the studies of DETC2014-35554 (Figs. 2, 3) and DETC2015-47747 (Fig. 2)."""
    from ..report.reproduce import reproduce
    from ..studies.builtin import BUILTIN_STUDIES

    if out is None:
        out = Path("roverimpact-results-quick" if quick else "roverimpact-results")
    here = compiles_here(workers, scheduler)
    if here:  # the longest compile (Lemke's impact kernel) in the background, the rest here
        from .._kernels.lemke import impact_kernel
        from .._kernels.partition import partition_kernel
        from .._kernels.reduced import rk4_peaks
        from ..models._assemble import _evaluate_one

        # the 3-D rover's assembly kernel too: the study processes forked from this one
        # start no compile of their own (each started one of the same kernel)
        compile_ahead(_evaluate_one, impact_kernel)
    counts: dict[str, tuple[int, int]] = {}  # study -> (done, total): one bar for all

    with progress_bar("reproduce") as update:
        def progress(name: str, done: int, total: int) -> None:
            counts[name] = (done, total)
            update(sum(d for d, _ in counts.values()), sum(t for _, t in counts.values()))

        res = reproduce(out, quick=quick, overwrite=overwrite, workers=workers,
                        scheduler=scheduler, n_boot=n_boot, progress=progress,
                        note=lambda text: err_console.print(f"note: {text}"),
                        prepare=(lambda: compile_ahead(now=(partition_kernel, rk4_peaks),
                                                       small=True, workers=workers is not None))
                        if here else None)
    import pandas as pd

    from ..studies.sweep import failed_simulations

    tables = [s.table for s in res.sections]
    bad = [failed_simulations(t) for t in tables]
    bad = [b for b in bad if not b.empty]
    failed = _failed_simulations(pd.concat(bad) if bad else pd.DataFrame(),
                                 sum(len(t) for t in tables), allow_failures)
    if as_json:
        print_json({"report": res.report.resolve(), "quick": quick,
                    "studies": _stats_json(res.sections)})
        return failed
    _print_stats(res.sections)
    for s in res.sections:
        fig = BUILTIN_STUDIES.get(s.folder.name, s.name)
        print_paths(fig, s.figures.get("png"), s.figures.get("svg"),
                    s.folder / "results.parquet")
    print_paths("report", res.report.resolve(), bold_path=True)
    return failed
