"""``roverimpact sweep | report | reproduce``: run studies, regenerate reports, reproduce papers.

Thin: parses, calls :mod:`roverimpact.studies` / :mod:`roverimpact.report`, prints.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from ._app import app, console, progress_bar


def _print_stats(sections) -> None:
    tab = Table(title="Indicator T_c^- vs simulated peak force F_max (95% bootstrap CI)")
    for col in ("study", "n", "Spearman", "Kendall", "Pearson", "concordant"):
        tab.add_column(col, justify="right" if col != "study" else "left")
    for s in sections:
        a = s.agreement
        if a is None:
            tab.add_row(s.folder.name, str(len(s.table)), "-", "-", "-", "F_max unavailable")
        else:
            tab.add_row(s.folder.name, str(a.n), str(a.spearman), str(a.kendall),
                        str(a.pearson), str(a.concordant_fraction))
    console.print(tab)


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
) -> None:
    """Run a study: every case's T_c^-, effective mass, predicted (and simulated) peak force."""
    from ..studies.sweep import run_study

    with progress_bar(study.stem) as update:
        res = run_study(study, out, resume=resume, overwrite=overwrite, csv=csv,
                        workers=workers, scheduler=scheduler, chunk_size=chunk_size,
                        progress=update)
    console.print(
        f"{len(res.table)} cases ({res.n_computed} computed, {res.n_reused} reused) in "
        f"{res.elapsed:.1f} s"
    )
    if report:
        from ..report.html import build_report

        path, sections = build_report(res.out_dir)
        _print_stats(sections)
        console.print(f"report: [bold]{path}[/bold]")
    for role, path in res.files.items():
        console.print(f"{role}: {path}")


@app.command("report")
def report_cmd(
    results: Path = typer.Argument(..., help="A results folder (of sweep or reproduce)."),
    n_boot: int = typer.Option(1000, "--n-boot", min=0, help="Bootstrap resamples."),
    seed: int = typer.Option(0, "--seed", help="Bootstrap seed."),
) -> None:
    """Regenerate the figures and the HTML report from saved results (no recomputation)."""
    from ..report.html import build_report

    path, sections = build_report(results, n_boot=n_boot, seed=seed)
    _print_stats(sections)
    for s in sections:
        console.print(f"figure: {s.figures.get('png')}")
    console.print(f"report: [bold]{path}[/bold]")


@app.command("reproduce")
def reproduce_cmd(
    out: Path = typer.Option(Path("roverimpact-results"), "-o", "--out", help="Output folder."),
    quick: bool = typer.Option(False, "--quick", help="Smoke run: 5 points per study."),
    workers: int = typer.Option(None, "--workers", help="Local Dask cluster of N processes."),
    scheduler: str = typer.Option(None, "--scheduler", help="Dask scheduler tcp://HOST:PORT."),
    n_boot: int = typer.Option(1000, "--n-boot", min=0, help="Bootstrap resamples."),
) -> None:
    """Reproduce the studies of DETC2014-35554 (Figs. 2, 3) and DETC2015-47747 (Fig. 2)."""
    from ..studies.reproduce import BUILTIN_STUDIES, reproduce

    with progress_bar("reproduce") as update:
        res = reproduce(out, quick=quick, workers=workers, scheduler=scheduler, n_boot=n_boot,
                        progress=lambda name, d, t: update(d, t))
    _print_stats(res.sections)
    if not res.simulated:
        console.print("[yellow]F_max unavailable: the simulator is not installed; only "
                      "T_c^- and the predicted peak force were computed.[/yellow]")
    for s in res.sections:
        fig = BUILTIN_STUDIES.get(s.folder.name, s.name)
        console.print(f"{fig}: {s.figures.get('png')}, {s.figures.get('svg')}, "
                      f"{s.folder / 'results.parquet'}")
    console.print(f"report: [bold]{res.report.resolve()}[/bold]")
