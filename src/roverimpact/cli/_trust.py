"""``roverimpact trust [STUDY] -o OUT``: Kendall tau of T_c^- vs F_max over contact parameters.

Thin: parses, calls :func:`roverimpact.studies.trust.trust_map`, prints.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from ._app import app, console, progress_bar


def _floats(text: str | None, what: str) -> list[float] | None:
    from ..exceptions import ConfigError

    if not text:
        return None
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ConfigError(f"--{what}: give comma-separated numbers, got {text!r}") from None


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
) -> None:
    """Trust map: where the T_c^- ranking agrees with the simulated F_max ranking."""
    from ..studies.trust import grid_from_options, trust_map

    grid = grid_from_options(laws.split(",") if laws else None, _floats(k, "k"),
                             _floats(e, "e"), quick=quick)
    with progress_bar("trust map", unit="runs") as update:
        res = trust_map(study, out, grid=grid, quick=quick, workers=workers, resume=resume,
                        overwrite=overwrite, progress=update)
    tab = Table(title=f"Kendall tau of T_c^- vs F_max ({res.n_configs} configurations)")
    for col in ("law", "k [N/m^n]", "e", "tau", "Spearman", "n", "failed"):
        tab.add_column(col, justify="left" if col == "law" else "right")
    for r in res.table.itertuples(index=False):
        tab.add_row(r.law, f"{r.k:.3g}", f"{r.e:.2f}", f"{r.tau:.3f}", f"{r.spearman:.3f}",
                    str(r.n), str(r.n_failed))
    console.print(tab)
    console.print(f"{len(res.results)} simulations in {res.elapsed:.1f} s")
    for role in ("trust", "results", "png", "svg"):
        if role in res.files:
            console.print(f"{role}: {res.files[role]}")
