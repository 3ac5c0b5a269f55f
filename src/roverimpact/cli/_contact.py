"""``roverimpact contact``: peak force, indentation, duration and rebound of one impact."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from ..contact import LAWS, get_law, impact_1dof, predict
from ._app import app, console


@app.command("contact")
def contact_cmd(
    law: str = typer.Option("hunt-crossley", "--law", help="Contact law (see --list)."),
    k: float = typer.Option(None, "--k", help="Stiffness k [N/m^n]."),
    e: float = typer.Option(None, "--e", help="Coefficient of restitution."),
    n: float = typer.Option(None, "--n", help="Exponent n (default 1.5; kelvin-voigt: 1)."),
    c: float = typer.Option(None, "--c", help="Kelvin-Voigt damping c [N s/m]."),
    mass: float = typer.Option(None, "--mass", help="Effective mass m_eff [kg]."),
    speed: float = typer.Option(None, "--speed", help="Normal approach speed v_n [m/s]."),
    T_c: float = typer.Option(None, "--tc", help="Effective kinetic energy T_c^- [J] "
                              "(instead of --mass: m_eff = 2 T_c^-/v_n^2)."),
    check: bool = typer.Option(False, "--check", help="Also integrate the impact numerically."),
    plot: Path = typer.Option(None, "--plot", help="Draw the force-indentation loop (PNG)."),
    list_laws: bool = typer.Option(False, "--list", help="List the laws and their references."),
) -> None:
    """Predict peak force, maximum indentation, contact duration and rebound of an impact."""
    if list_laws:
        t = Table(title="Contact laws")
        for col in ("name", "law", "reference"):
            t.add_column(col)
        for name, cls in LAWS.items():
            t.add_row(name, cls.equation, cls.reference)
        console.print(t)
        return
    if k is None or speed is None or (mass is None) == (T_c is None):
        raise typer.BadParameter("give --k, --speed and exactly one of --mass / --tc")
    if T_c is not None:
        if speed <= 0:
            raise typer.BadParameter("--speed must be > 0", param_hint="--speed")
        mass = 2.0 * T_c / speed**2
    the_law = get_law(law, k=k, e=e, n=n, c=c,
                      m_eff=mass if law.replace("_", "-") == "kelvin-voigt" else None)
    p = predict(the_law, mass, speed)
    r = impact_1dof(the_law, mass, speed) if (check or plot) else None
    t = Table(title=f"{the_law.name}: m_eff = {mass:.6g} kg, v_n = {speed:.6g} m/s, "
                    f"T_c^- = {0.5 * mass * speed**2:.6g} J")
    t.add_column("quantity")
    t.add_column("closed form", justify="right")
    if check:
        t.add_column("integrated", justify="right")
        t.add_column("rel. diff", justify="right")
    rows = [("peak force [N]", "peak_force", 1.0), ("max indentation [mm]", "max_indentation",
            1e3), ("contact duration [ms]", "duration", 1e3),
            ("achieved restitution e*", "restitution_achieved", 1.0),
            ("energy dissipated [J]", "energy_dissipated", 1.0)]
    for label, field, scale in rows:
        a = getattr(p, field)
        cells = [escape(label), f"{scale * a:.6g}"]
        if check:
            b = getattr(r, field)
            rel = abs(a - b) / abs(b) if b else abs(a - b)
            cells += [f"{scale * b:.6g}", f"{rel:.1e}"]
        t.add_row(*cells)
    console.print(t)
    if plot is not None:
        from ..contact.plots import plot_hysteresis_loops

        plot_hysteresis_loops([the_law], mass, speed, plot)
        console.print(f"loop written to {plot}")
