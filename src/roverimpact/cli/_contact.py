"""``roverimpact contact``: peak force, indentation, duration and rebound of one impact."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from ._app import app, check_output, console, new_table, print_json
from ._draw import IMAGE_TYPES


def _positive(value: float | None, option: str, what: str, unit: str) -> None:
    """--mass / --speed / --tc: finite and > 0, named as the user typed them."""
    from ..exceptions import InputError

    if value is not None and not (math.isfinite(value) and value > 0):
        raise InputError(f"{option} ({what}) must be a finite number > 0 {unit}, got {value:g}")


def _in_range(value: float, what: str, unit: str) -> None:
    """A quantity computed from finite options overflowed (inf) or underflowed (0)."""
    from ..exceptions import InputError

    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{what} = {value:g} {unit}: out of floating-point range")


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
    plot: Path = typer.Option(None, "--plot", help="Draw the force-indentation loop "
                              "(.png, .svg, .pdf)."),
    list_laws: bool = typer.Option(False, "--list", help="List the laws and their references."),
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable JSON."),
) -> None:
    """Predict peak force, maximum indentation, contact duration and rebound of an impact."""
    from ..contact import LAWS, get_law, impact_1dof, predict
    from ..contact.hertz import hertz_scales

    if list_laws:
        laws = [{"name": name, "law": cls.equation,
                 "parameters": {p: par.default for p, par in cls.parameters.items()},
                 "reference": cls.reference} for name, cls in LAWS.items()]
        if as_json:
            print_json({"laws": laws})
            return
        t = new_table("Contact laws", "name", "law", "parameters", "reference",
                      left=("law", "parameters", "reference"))
        for d in laws:
            pars = ", ".join(p if v is None else f"{p} = {v:g}"
                             for p, v in d["parameters"].items())
            t.add_row(d["name"], d["law"], pars, d["reference"])
        console.print(t)
        return
    if k is None or speed is None or (mass is None) == (T_c is None):
        raise typer.BadParameter("give --k, --speed and exactly one of --mass / --tc")
    _positive(speed, "--speed", "normal approach speed v_n", "m/s")
    _positive(mass, "--mass", "effective mass m_eff", "kg")
    _positive(T_c, "--tc", "effective kinetic energy T_c^-", "J")
    if plot is not None:
        check_output(plot, folder=False, option="--plot", suffixes=IMAGE_TYPES)
    if T_c is not None:
        mass = 2.0 * T_c / speed / speed
        _in_range(mass, f"--tc {T_c:g} J at --speed {speed:g} m/s gives the effective mass "
                  "m_eff = 2 T_c^-/v_n^2", "kg")
    _in_range(0.5 * mass * speed * speed, f"--mass {mass:g} kg at --speed {speed:g} m/s "
              "gives the kinetic energy T_c^- = 1/2 m_eff v_n^2", "J")
    the_law = get_law(law, k=k, e=e, n=n, c=c, m_eff=mass)  # m_eff: used if the law needs it
    p = predict(the_law, mass, speed)
    # integrate for as long as the closed form says the contact lasts (twice, at least
    # impact_1dof's 1e4 Hertz times): gonthier at e = 1e-8 lasts 8e4 Hertz times
    d_H, _ = hertz_scales(mass, speed, the_law.k, the_law.n)
    horizon = 2.0 * float(p.duration) * speed / float(d_H)
    horizon = horizon if math.isfinite(horizon) and horizon > 1e4 else 1e4
    r = impact_1dof(the_law, mass, speed, max_duration=horizon) if (check or plot) else None
    rows = [("peak force [N]", "peak_force", 1.0), ("max indentation [mm]", "max_indentation",
            1e3), ("contact duration [ms]", "duration", 1e3),
            ("achieved restitution e*", "restitution_achieved", 1.0),
            ("energy dissipated [J]", "energy_dissipated", 1.0)]
    if as_json:
        fields = [f for _, f, _ in rows]
        out = {"law": the_law.name, "m_eff": mass, "v_n": speed,
               "T_c_minus": 0.5 * mass * speed * speed,
               "closed_form": {f: getattr(p, f) for f in fields}}
        if check:
            out["integrated"] = {f: getattr(r, f) for f in fields}
    else:
        t = new_table(f"{the_law.name}: m_eff = {mass:.6g} kg, v_n = {speed:.6g} m/s, "
                      f"T_c^- = {0.5 * mass * speed * speed:.6g} J", "quantity", "closed form",
                      *(["integrated", "rel. diff"] if check else []))
        T = 0.5 * mass * speed * speed
        for label, field, scale in rows:
            a = getattr(p, field)
            cells = [label, f"{scale * a:.6g}"]
            if check:
                b = getattr(r, field)
                # the energy dissipated is compared with T_c^-, the energy it is a part
                # of: relative to itself, an elastic law's 0 J against the integrator's
                # 4e-12 J read as a difference of 1.0 (100 %)
                ref = T if field == "energy_dissipated" else abs(b)
                rel = abs(a - b) / ref if ref else abs(a - b)
                cells += [f"{scale * b:.6g}", f"{rel:.1e}"]
            t.add_row(*cells)
        if check:
            t.caption = "rel. diff: |closed form - integrated| / |integrated|; for the " \
                        "energy dissipated, / T_c^-."
    if plot is not None:
        from ..report.contact import plot_hysteresis_loops

        plot_hysteresis_loops([the_law], mass, speed, plot, max_duration=horizon)
    if as_json:
        print_json(out | ({"plot": plot} if plot is not None else {}))
        return
    console.print(t)
    if plot is not None:
        console.print(f"loop written to {plot}", highlight=False)
