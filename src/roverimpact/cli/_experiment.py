"""``roverimpact experiment TRIALS.toml -o OUTDIR``: force-sensor trials vs the model."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from .._io import staged_folder
from ._app import (
    app,
    check_output,
    console,
    err_console,
    new_table,
    one_format,
    print_csv,
    print_json,
    print_paths,
)

#: What an experiment run writes, by exact name: a folder holding these and trials.csv +
#: summary.json is a previous run, replaced by the next one (a user's file beside them,
#: such as inputs_notes.txt, makes the run refuse the folder rather than delete it); the
#: copies of the inputs are ``roverimpact.experiments.pipeline.INPUT_COPIES``
EXPERIMENT_FILES = ("impacts.csv", "trials.csv", "failures.csv", "comparison.csv",
                    "summary.json", "inputs_trials.toml", "inputs_scenario.toml",
                    "overlay.png")

#: The per-trial table: header (with unit) and column of ``ExperimentResult.trials`` (SI:
#: the CSV gives the duration in s, the table in ms).
_TRIAL_COLUMNS = (("trial", "trial"), ("file", "file"), ("beta [deg]", "beta_deg"),
                  ("speed [m/s]", "speed"), ("F_peak [N]", "F_peak"),
                  ("impulse [N s]", "impulse"), ("duration [ms]", "duration"),
                  ("impacts", "n_impacts"))


@app.command("experiment")
def experiment_cmd(
    trials: Path = typer.Argument(..., help="Trials file (TOML): sensors, filter, trials, model."),
    outdir: Path = typer.Option(Path("experiment_out"), "-o", "--outdir",
                                help="Directory for tables, plot and a copy of the inputs."),
    no_plot: bool = typer.Option(False, "--no-plot", help="Skip the overlay figure."),
    as_json: bool = typer.Option(False, "--json", help="Print the trials, the comparison "
                                 "and the failures as JSON."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the per-trial table as CSV "
                                "(duration in s)."),
    no_simulate: bool = typer.Option(False, "--no-simulate", help="Compare the peaks with "
                                     "the model's T_c^- alone: no simulation, no F_max "
                                     "(as [model] simulate = false)."),
) -> int:
    """Detect impacts in force recordings, measure peak/impulse/duration, compare with the model.

    Exit code 0 if at least one trial ran (failures are listed), 2 if none did (then
    nothing is written).
    """
    one_format(as_json, as_csv)
    from ..experiments import (
        compare_with_model,
        load_trials,
        run_experiment,
        scenario_model,
        write_outputs,
    )

    check_output(outdir, folder=True)
    cfg, base = load_trials(trials)
    # a missing or invalid scenario is told before the recordings are processed
    if no_simulate and cfg.model is not None:  # as the file's simulate = false (summary)
        cfg = cfg.model_copy(update={"model": cfg.model.model_copy(update={"simulate": False})})
    model = scenario_model(cfg.model, base) if cfg.model is not None else None
    with staged_folder(outdir, EXPERIMENT_FILES, ("trials.csv", "summary.json"),
                       "experiment") as work:
        result = run_experiment(cfg, base)
        result.require_trials()
        comparison = None
        if model is not None:
            comparison = compare_with_model(result.trials, model)
        files = write_outputs(result, work, comparison=comparison, trials_path=trials)
        if not no_plot:
            from ..report.experiment import plot_overlay

            files["plot"] = plot_overlay(result.trials, comparison, work / "overlay.png")
    files = {k: Path(outdir) / Path(p).name for k, p in files.items()}

    df = result.trials
    if as_json:
        print_json({
            "trials": df.to_dict(orient="records"),
            "comparison": (comparison.table.to_dict(orient="records")
                           if comparison is not None else None),
            "rank_agreement": comparison.stats if comparison is not None else None,
            "baselines": (comparison.indicators.as_dict()
                          if comparison is not None and comparison.indicators is not None
                          else None),
            "failures": result.failures_table.to_dict(orient="records"),
            "outputs": files,
        })
        return 0
    if as_csv:
        cols = [c for _, c in _TRIAL_COLUMNS]
        print_csv(cols, df[cols].itertuples(index=False))
        return 0
    tab = new_table(f"Impacts in {trials.name} (main impact per trial)",
                    *(h for h, _ in _TRIAL_COLUMNS), left=("file",), right=("trial",))
    for r in df.itertuples():
        tab.add_row(str(r.trial), r.file, f"{r.beta_deg:g}", f"{r.speed:g}",
                    f"{r.F_peak:.1f}", f"{r.impulse:.4g}", f"{1e3 * r.duration:.2f}",
                    str(r.n_impacts))
    console.print(tab)
    if comparison is not None:
        s = comparison.stats
        simulated = model.simulate
        ct = new_table(f"Model comparison ({cfg.model.scenario}: scenario T_c^-"
                       + (" and simulated F_max)" if simulated else ", not simulated)"),
                       "beta [deg]", "speed [m/s]", "n", "F_peak mean [N]", "T_c^- [J]",
                       *(("F_max model [N]", "measured/model") if simulated else ()))
        for r in comparison.table.itertuples():
            ct.add_row(f"{r.beta_deg:g}", f"{r.speed:g}", str(r.n), f"{r.F_peak_mean:.1f}",
                       f"{r.T_c_minus:.4g}",
                       *((f"{r.F_max:.1f}", f"{r.F_ratio:.3f}") if simulated else ()))
        console.print(ct)

        def fmt(x):
            return "n/a (< 3 conditions)" if math.isnan(x) else f"{x:.3f}"

        def ranks(key):  # the statistics with their p-values and the number of conditions
            tau, rho = s[f"kendall_tau_{key}"], s[f"spearman_rho_{key}"]
            if math.isnan(tau):
                return f"Kendall tau = {fmt(tau)}, Spearman rho = {fmt(rho)}"
            return (f"Kendall tau = {fmt(tau)} (p = {s[f'kendall_p_{key}']:.2g}), Spearman "
                    f"rho = {fmt(rho)} (p = {s[f'spearman_p_{key}']:.2g}) over "
                    f"{s[f'n_conditions_{key}']} conditions")

        console.print(
            f"rank agreement, peak vs T_c^-: {ranks('Tc')}"
            + (f"; peak vs model F_max: {ranks('Fmax')}" if simulated else ""),
            highlight=False,
        )
        if comparison.indicators is not None:
            parts = [f"{r.label} {'const.' if r.constant else fmt(r.agreement.spearman.value)}"
                     for r in comparison.indicators.results]
            console.print("Spearman rho of the measured peak with " + ", ".join(parts)
                          + " (same conditions)", highlight=False)
            for t in comparison.indicators.statements:
                if t.startswith("In short: "):
                    console.print(t, highlight=False)
    for w in result.warnings:
        err_console.print(f"warning: {w}", highlight=False)
    if result.failures:
        ft = new_table(f"{len(result.failures)} trial(s) failed", "trial", "file", "problem",
                       left=("file", "problem"), right=("trial",))
        ft.style = "red"
        for f in result.failures:
            ft.add_row(str(f.trial), f.file, f.message)
        err_console.print(ft)
    print_paths("outputs", outdir)
    console.print("  " + ", ".join(p.name for p in files.values()), highlight=False)
    return 0
