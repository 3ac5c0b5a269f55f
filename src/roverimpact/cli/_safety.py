"""``roverimpact safety ...``: ISO/TS 15066 transient-contact limits for robot arms."""

from __future__ import annotations

import math

import numpy as np
import typer
from rich.table import Table

from ..exceptions import InputError
from ..safety import (
    BODY_REGIONS,
    ISO_TS_15066_SOURCE,
    READY_POSES,
    arm_effective_masses,
    iso_robot_mass,
    load_arm,
    max_transient_speed,
    reduced_mass,
)
from ._app import app, console

safety_app = typer.Typer(help="ISO/TS 15066 transient contact: body regions, speed limits, arms.",
                         no_args_is_help=True)
app.add_typer(safety_app, name="safety")


def _fmt_v(region, m_R) -> str:
    if region.F_transient is None:
        return "not permitted"
    return f"{max_transient_speed(region, m_R):.3f}"


@safety_app.command("regions")
def regions_cmd(
    robot_mass: float = typer.Option(None, "--robot-mass", help="Total moving mass M [kg]: "
                                     "adds the speed limit with m_R = M/2 + payload."),
    payload: float = typer.Option(0.0, "--payload", help="Payload m_L [kg]."),
) -> None:
    """The standard's body regions (m_H, K, force limits) and optional speed limits."""
    m_R = None if robot_mass is None else float(iso_robot_mass(robot_mass, payload))
    tab = Table(title="ISO/TS 15066:2016 body regions (Tables A.2, A.3)")
    for col in ("region", "m_H [kg]", "K [N/mm]", "F_qs [N]", "F_transient [N]"):
        tab.add_column(col, justify="left" if col == "region" else "right")
    if m_R is not None:
        tab.add_column(f"mu [kg] (m_R={m_R:g})", justify="right")
        tab.add_column("v_max [m/s]", justify="right")
    for r in BODY_REGIONS.values():
        row = [r.name, f"{r.m_H:g}", f"{r.K / 1e3:g}", f"{r.F_qs:g}",
               "-" if r.F_transient is None else f"{r.F_transient:g}"]
        if m_R is not None:
            row += [f"{reduced_mass(r.m_H, m_R):.3f}", _fmt_v(r, m_R)]
        tab.add_row(*row)
    console.print(tab)
    console.print(f"source: {ISO_TS_15066_SOURCE}", highlight=False)


@safety_app.command("arm")
def arm_cmd(
    robot: str = typer.Argument(..., help="URDF file or erd:<name> (example-robot-data)."),
    q: str = typer.Option(None, "--q", help="Configuration, comma-separated (rad / m); "
                          "default: the ready pose for known robots, else the neutral one."),
    payload: float = typer.Option(0.0, "--payload", help="Payload m_L [kg] (ISO formula)."),
    region: str = typer.Option("chest", "--region", help="Body region for the speed limits."),
    points: str = typer.Option("com", "--points", help="'com' or 'origin' of each link."),
) -> None:
    """Per link: the standard's m_R = M/2 + m_L vs the exact effective mass, and v_max."""
    import pinocchio as pin

    model = load_arm(robot)
    if q is not None:
        try:
            qv = np.array([float(x) for x in q.split(",")])
        except ValueError:
            raise InputError(f"--q must be comma-separated numbers, got {q!r}") from None
    elif robot.startswith("erd:") and robot[4:] in READY_POSES:
        qv = np.array(READY_POSES[robot[4:]])
    else:
        qv = pin.neutral(model)
    df = arm_effective_masses(model, qv, payload=payload, points=points, region=region)
    tab = Table(title=f"{robot}: effective mass per link ({points}), region {region}")
    cols = ["link", "m_R ISO [kg]", "m_min [kg]", "m_max [kg]", "m_min/m_R"]
    if "v_iso" in df:
        cols += ["v ISO [m/s]", "v exact, worst dir.", "v exact, best dir."]
    for c in cols:
        tab.add_column(c, justify="left" if c == "link" else "right")

    def f(x):
        return "inf" if math.isinf(x) else f"{x:.3f}"

    for r in df.itertuples():
        row = [r.link, f(r.m_R_iso), f(r.m_min), f(r.m_max), f(r.ratio_min)]
        if "v_iso" in df:
            row += [f(r.v_iso), f(r.v_exact_worst), f(r.v_exact_best)]
        tab.add_row(*row)
    console.print(tab)
    console.print(f"M (moving parts) = {df.attrs['M_total']:.3f} kg, payload {payload:g} kg, "
                  f"q = {np.round(qv, 4).tolist()}", highlight=False)
