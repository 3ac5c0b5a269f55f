"""``roverimpact optimize FILE``: suspension setting of minimum worst-case T_c^-.

Thin: parses, calls :func:`roverimpact.studies.optimize.optimize_setting`, prints.
"""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from ._app import app, console


@app.command("optimize")
def optimize_cmd(
    file: Path = typer.Argument(..., help="Optimisation file (TOML): [scenario], [optimize]."),
    simulate: bool = typer.Option(True, "--simulate/--no-simulate",
                                  help="Confirm nominal and optimum with the simulator."),
    plot: Path = typer.Option(None, "--plot", help="Write T_c^- vs beta to PATH.png/.svg."),
) -> None:
    """Suspension reconfiguration: minimise the worst-case (or mean) T_c^- over beta."""
    from ..studies.optimize import optimize_setting, plot_reconfiguration

    res = optimize_setting(file, simulate=simulate)
    spec = res.problem.spec
    tab = Table(title=f"Suspension setting ({spec.objective}-case T_c^-, beta "
                      f"{spec.beta_deg[0]:g}-{spec.beta_deg[1]:g} deg)")
    for col in ("", "nominal", "optimum"):
        tab.add_column(col, justify="left" if not col else "right")
    for name in res.problem.names:
        tab.add_row(name, f"{res.nominal.values[name]:.4g}", f"{res.best.values[name]:.4g}")
    n, b = res.nominal, res.best
    tab.add_row(escape(f"{spec.objective} T_c^- [J]"), f"{n.objective:.4g}", f"{b.objective:.4g}")
    tab.add_row(escape("worst beta [deg]"), f"{n.beta_worst_deg:.3g}", f"{b.beta_worst_deg:.3g}")
    tab.add_row(escape("predicted F_max [N]"), f"{n.F_pred:.4g}", f"{b.F_pred:.4g}")
    if simulate:
        tab.add_row(escape("simulated F_max [N]"), f"{res.F_sim_nominal:.4g}",
                    f"{res.F_sim_best:.4g}")
    tab.add_row(escape("stability margin [m]"), f"{n.margin:.4g}", f"{b.margin:.4g}")
    tab.add_row(escape("clearance [m]"), f"{n.clearance:.4g}", f"{b.clearance:.4g}")
    console.print(tab)
    console.print(f"T_c^- reduced by {100 * res.reduction:.1f} %")
    if simulate:
        console.print(f"simulated peak force at beta = {res.sim_betas_deg} deg: "
                      f"{res.F_sim_nominal:.4g} N -> {res.F_sim_best:.4g} N")
    if plot is not None:
        for path in plot_reconfiguration(res, plot).values():
            console.print(f"figure: {path}")
