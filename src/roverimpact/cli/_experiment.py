"""``roverimpact experiment TRIALS.toml -o OUTDIR``: force-sensor trials vs the model."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.table import Table

from ..studies.experiment import compare_with_model, load_trials, run_experiment, write_outputs
from ._app import app, console, err_console


@app.command("experiment")
def experiment_cmd(
    trials: Path = typer.Argument(..., help="Trials file (TOML): sensors, filter, trials, model."),
    outdir: Path = typer.Option(Path("experiment_out"), "-o", "--outdir",
                                help="Directory for tables, plot and a copy of the inputs."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the overlay figure."),
) -> int:
    """Detect impacts in force recordings, measure peak/impulse/duration, compare with the model.

    Exit code 0 if at least one trial ran (failures are listed), 2 if none did.
    """
    cfg, base = load_trials(trials)
    result = run_experiment(cfg, base)
    comparison = None
    if cfg.model is not None and not result.trials.empty:
        comparison = compare_with_model(result.trials, cfg.model.build(base))
    files = write_outputs(result, outdir, comparison=comparison, trials_path=trials,
                          plot=not no_plot)

    if not result.trials.empty:
        tab = Table(title=f"Impacts in {trials.name} (main impact per trial)")
        for col in ("trial", "file", "beta [deg]", "speed [m/s]", "F_peak [N]",
                    "impulse [N s]", "duration [ms]", "impacts"):
            tab.add_column(col, justify="left" if col == "file" else "right")
        for r in result.trials.itertuples():
            tab.add_row(str(r.trial), r.file, f"{r.beta_deg:g}", f"{r.speed:g}",
                        f"{r.F_peak:.1f}", f"{r.impulse:.4g}", f"{1e3 * r.duration:.2f}",
                        str(r.n_impacts))
        console.print(tab)
    if comparison is not None:
        s = comparison.stats
        ct = Table(title=f"Model comparison ({cfg.model.scenario}: scenario T_c^- and "
                           "simulated F_max)")
        for col in ("beta [deg]", "speed [m/s]", "n", "F_peak mean [N]", "T_c^- [J]",
                    "F_max model [N]", "measured/model"):
            ct.add_column(col, justify="right")
        for r in comparison.table.itertuples():
            ct.add_row(f"{r.beta_deg:g}", f"{r.speed:g}", str(r.n), f"{r.F_peak_mean:.1f}",
                       f"{r.T_c_minus:.4g}", f"{r.F_max:.1f}", f"{r.F_ratio:.3f}")
        console.print(ct)

        def fmt(x):
            return "n/a (< 3 conditions)" if math.isnan(x) else f"{x:.3f}"

        console.print(
            f"rank agreement, peak vs T_c^-: Kendall tau = {fmt(s['kendall_tau_Tc'])}, "
            f"Spearman rho = {fmt(s['spearman_rho_Tc'])}; peak vs model F_max: Kendall tau = "
            f"{fmt(s['kendall_tau_Fmax'])}, Spearman rho = {fmt(s['spearman_rho_Fmax'])}",
            highlight=False,
        )
    if result.failures:
        ft = Table(title=f"{len(result.failures)} trial(s) failed", style="red")
        ft.add_column("trial", justify="right")
        ft.add_column("file")
        ft.add_column("problem")
        for f in result.failures:
            ft.add_row(str(f.trial), f.file, f.message)
        err_console.print(ft)
    console.print(f"outputs in {outdir}: " + ", ".join(p.name for p in files.values()),
                  highlight=False)
    if result.trials.empty:
        err_console.print("[bold red]error:[/bold red] no trial could be processed")
        return 2
    return 0
