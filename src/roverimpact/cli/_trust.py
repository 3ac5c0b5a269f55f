"""``roverimpact trust [STUDY] -o OUT``: Kendall tau of T_c^- vs F_max over contact parameters.

Thin: parses, calls :func:`roverimpact.studies.trust.trust_map`, prints.
"""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import (
    app,
    console,
    new_table,
    one_format,
    print_csv,
    print_json,
    print_paths,
    progress_bar,
)


def _floats(text: str | None, what: str) -> list[float] | None:
    from ..exceptions import ConfigError

    if not text:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(f"--{what}: give comma-separated numbers, got {text!r}") from None


def _complete(out: Path) -> bool:
    """Whether the study folder ``out`` holds a complete study (its manifest says so)."""
    from ..studies.store import read_manifest

    return (read_manifest(out) or {}).get("status") == "complete"


@app.command("trust")
def trust_cmd(
    study: Path = typer.Argument(None, help="Study file (TOML); default: built-in 2-D rover "
                                            "beta sweep."),
    out: Path = typer.Option(Path("trust"), "-o", "--out", help="Output folder."),
    quick: bool = typer.Option(False, "--quick", help="2x2 grid, one law (smoke test)."),
    laws: str = typer.Option(None, "--laws", help="Comma-separated contact laws."),
    k: str = typer.Option(None, "--k", help="Comma-separated stiffness values [N/m^n]."),
    e: str = typer.Option(None, "--e", help="Comma-separated restitution values."),
    workers: int = typer.Option(None, "--workers", help="Local Dask cluster of N processes."),
    resume: bool = typer.Option(False, "--resume", help="Continue an interrupted run."),
    overwrite: bool = typer.Option(False, "--overwrite", help="Discard results in the folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the table as JSON (the progress "
                                 "bar goes to stderr)."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the table as CSV."),
    engine: str = typer.Option("own", "--engine", help="Simulator(s), comma-separated: own, "
                               "mujoco, mujoco_laws (MuJoCo with the cell's law; "
                               "frictionless), e.g. own,mujoco (one map per engine)."),
) -> None:
    """Trust map: where the T_c^- ranking agrees with the simulated F_max ranking."""
    one_format(as_json, as_csv)
    from ..exceptions import StudyInterrupted
    from ..report.trust import plot_trust_map
    from ..studies.trust import FIGURE_STEM, grid_from_options, trust_map

    engines = [x.strip() for x in engine.split(",") if x.strip()] or [engine]
    grid = grid_from_options(laws.split(",") if laws else None, _floats(k, "k"),
                             _floats(e, "e"), quick=quick)
    try:
        with progress_bar("trust map", unit="runs") as update:
            res = trust_map(study, out, grid=grid, quick=quick, workers=workers,
                            resume=resume, overwrite=overwrite, progress=update,
                            engines=engines)
        res.files.update(plot_trust_map(res.table, res.out_dir / FIGURE_STEM,
                                        title=res.title))
    except StudyInterrupted:  # in the simulations: says what is kept
        raise
    except KeyboardInterrupt:
        if not _complete(out):
            raise
        # a bare "interrupted" said nothing of the simulations, all done
        raise StudyInterrupted(
            f"interrupted after the simulations, which are complete in {out}: rerun the "
            "same command with --resume to write the trust map (nothing is "
            "recomputed)") from None
    n_sims = len(res.results) * res.table["engine"].nunique()
    cols = ["law", "k", "e", "tau", "spearman", "n", "n_failed", "engine", "spearman_v_n",
            "spearman_T_n_total", "spearman_T_c_obstacle"]
    if as_json:
        print_json({"configurations": res.n_configs, "simulations": n_sims,
                    "elapsed_s": res.elapsed, "files": res.files,
                    "table": res.table[cols].to_dict(orient="records")})
        return
    if as_csv:
        print_csv(cols, res.table[cols].itertuples(index=False))
        return
    from ..report.plots import ENGINE_LABELS

    def rho(x):
        return "n/a" if x != x else f"{x:.3f}"

    for eng, sub in res.table.groupby("engine", sort=False):
        label = ENGINE_LABELS.get(eng, eng)
        tab = new_table(f"Kendall tau of T_c^- vs F_max, {label} ({res.n_configs} "
                        "configurations)", "law", "k [N/m^n]", "e", "tau", "Spearman", "n",
                        "failed")
        base = new_table(f"Rank correlation rho with F_max, {label}: T_c^- and the "
                         "baselines",
                         "law", "k [N/m^n]", "e", "T_c^-", "v_n", "m_total v_n^2/2",
                         "T_c^- obst. row")
        base.caption = ("Same F_max for every indicator. T_c^- obst. row: T_c^- with the "
                        "obstacle row only. n/a: the indicator is the same for every "
                        "configuration (it cannot rank them), or fewer than 3 simulations.")
        for r in sub.itertuples(index=False):
            tab.add_row(r.law, f"{r.k:.3g}", f"{r.e:.2f}", f"{r.tau:.3f}",
                        f"{r.spearman:.3f}", str(r.n), str(r.n_failed))
            base.add_row(r.law, f"{r.k:.3g}", f"{r.e:.2f}", rho(r.spearman),
                         rho(r.spearman_v_n), rho(r.spearman_T_n_total),
                         rho(r.spearman_T_c_obstacle))
        console.print(tab)
        console.print(base)
    console.print(f"{n_sims} simulations in {res.elapsed:.1f} s")
    for role in ("trust", "results", "png", "svg"):
        if role in res.files:
            print_paths(role, res.files[role])
