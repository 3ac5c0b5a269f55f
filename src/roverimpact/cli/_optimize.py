"""``roverimpact optimize FILE``: suspension setting of minimum worst-case T_c^-.

Thin: parses, calls :func:`roverimpact.studies.optimize.optimize_setting`, prints.
"""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import (
    app,
    check_output,
    console,
    new_table,
    print_json,
    print_paths,
    progress_bar,
)


@app.command("optimize")
def optimize_cmd(
    file: Path = typer.Argument(..., help="Optimisation file (TOML): [scenario], [optimize]."),
    simulate: bool = typer.Option(True, "--simulate/--no-simulate",
                                  help="Confirm nominal and optimum with the simulator."),
    plot: Path = typer.Option(None, "--plot", help="Write T_c^- vs beta to PATH (.png, .svg, "
                              ".pdf), or to PATH.png and PATH.svg."),
    as_json: bool = typer.Option(False, "--json", help="Print nominal and optimum as JSON."),
) -> None:
    """Suspension reconfiguration: minimise the worst-case (or mean) T_c^- over beta."""
    from ..report.plots import figure_files
    from ..report.reconfiguration import plot_reconfiguration
    from ..studies.optimize import optimize_setting, param_unit

    for path in figure_files(plot) if plot is not None else ():
        check_output(path, folder=False, option="--plot")
    with progress_bar("optimize", unit="starts + simulations") as update:
        res = optimize_setting(file, simulate=simulate, progress=update)
    spec = res.problem.spec
    figures = plot_reconfiguration(res, plot) if plot is not None else {}
    n, b = res.nominal, res.best
    if as_json:
        def point(p, F_sim):
            return {"values": p.values, "objective_T_c_minus": p.objective,
                    "beta_worst_deg": p.beta_worst_deg, "F_pred": p.F_pred,
                    "F_sim": F_sim, "stability_margin": p.margin, "clearance": p.clearance}

        print_json({"objective": spec.objective, "beta_deg": spec.beta_deg,
                    "nominal": point(n, res.F_sim_nominal if simulate else None),
                    "optimum": point(b, res.F_sim_best if simulate else None),
                    "reduction": res.reduction, "nominal_in_bounds": res.nominal_in_bounds,
                    "at_bound": res.at_bound(),
                    "active_constraints": res.active_constraints(),
                    "nominal_violations": res.nominal_violations(),
                    "units": {**{k: param_unit(k) for k in res.problem.names},
                              "objective_T_c_minus": "J", "beta_worst_deg": "deg",
                              "F_pred": "N", "F_sim": "N", "stability_margin": "m",
                              "clearance": "m"},
                    "figures": figures})
        return
    tab = new_table(f"Suspension setting ({spec.objective}-case T_c^-, beta "
                    f"{spec.beta_deg[0]:g}-{spec.beta_deg[1]:g} deg)", "", "nominal", "optimum")
    at_bound, active = res.at_bound(), res.active_constraints()

    def note(text):
        return f" ({text})" if text else ""

    for name in res.problem.names:
        tab.add_row(f"{name} [{param_unit(name)}]", f"{n.values[name]:.4g}",
                    f"{b.values[name]:.4g}{note(at_bound.get(name))}")
    tab.add_row(f"{spec.objective} T_c^- [J]", f"{n.objective:.4g}", f"{b.objective:.4g}")
    tab.add_row("worst beta [deg]", f"{n.beta_worst_deg:.3g}", f"{b.beta_worst_deg:.3g}")
    tab.add_row("predicted F_max [N]", f"{n.F_pred:.4g}", f"{b.F_pred:.4g}")
    if simulate:
        tab.add_row("simulated F_max [N]", f"{res.F_sim_nominal:.4g}", f"{res.F_sim_best:.4g}")
    tab.add_row("stability margin [m]", f"{n.margin:.4g}",
                f"{b.margin:.4g}{note('active' if 'stability margin' in active else '')}")
    tab.add_row("clearance [m]", f"{n.clearance:.4g}",
                f"{b.clearance:.4g}{note('active' if 'clearance' in active else '')}")
    console.print(tab)
    console.print(f"T_c^- reduced by {100 * res.reduction:.1f} %")
    if at_bound:
        console.print("note: the optimum lies on a bound (" + ", ".join(
            f"{k}: {v}" for k, v in at_bound.items()) + "): a wider range may lower T_c^- "
            "further", highlight=False)
    violated = res.nominal_violations()
    if violated:
        console.print("note: the nominal setting violates the limits (" + ", ".join(violated)
                      + "): the reduction is measured from a setting they refuse",
                      highlight=False)
    if not res.nominal_in_bounds:
        console.print("note: the nominal setting lies outside the bounds of [optimize] "
                      "variables, so it was not a candidate: the optimum is the best setting "
                      "inside them, compared with the nominal", highlight=False)
    if simulate:
        console.print(f"simulated peak force at beta = {res.sim_betas_deg} deg: "
                      f"{res.F_sim_nominal:.4g} N -> {res.F_sim_best:.4g} N", highlight=False)
    for path in figures.values():
        print_paths("figure", path)
