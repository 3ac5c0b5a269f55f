"""``roverimpact partition FILE``: energy partition of a system given as M, A, v."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from .._io import load_system
from ..energy import partition
from ..impulse import impulsive_impact
from ._app import app, console


@app.command("partition")
def partition_cmd(
    file: Path = typer.Argument(..., help="A .npz or .toml file with arrays M, A and v."),
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable JSON."),
) -> None:
    """Split the kinetic energy of (M, A, v) into T_c and T_a and show the impact map.

    If the file gives a ``restitution``, the impulsive impact of the rows of A is shown too.
    """
    data = load_system(file)
    p = partition(data["M"], data["A"], data["v"])
    imp = None
    if "restitution" in data:
        imp = impulsive_impact(
            data["M"], data["A"], data["v"], data["restitution"], data.get("persistent")
        )
    if np.ndim(p.T) != 0:
        raise typer.BadParameter("partition FILE takes one system, not a batch", param_hint="FILE")
    names = data.get("names") or [f"q{i}" for i in range(len(p.v_c))]
    if as_json:
        out = {
            "T": float(p.T), "T_c": float(p.T_c), "T_a": float(p.T_a), "rank": int(p.rank),
            "v_c": p.v_c.tolist(), "v_a": p.v_a.tolist(),
        }
        if imp is not None:
            out |= {"v_plus": imp.v_plus.tolist(), "impulse": imp.impulse.tolist(),
                    "energy_lost": float(imp.energy_lost)}
        console.print_json(json.dumps(out))
        return
    if "description" in data:
        console.print(f"[bold]{data['description']}[/bold]")
    summary = Table(title=f"Kinetic-energy partition of {file.name}", show_header=True)
    summary.add_column("quantity")
    summary.add_column("value", justify="right")
    summary.add_column("share", justify="right")
    share = (lambda x: f"{100 * x / p.T:.1f} %") if p.T > 0 else (lambda x: "-")
    summary.add_row("T  (total)", f"{p.T:.6g} J", share(p.T))
    summary.add_row("T_c (constrained, effective)", f"{p.T_c:.6g} J", share(p.T_c))
    summary.add_row("T_a (admissible)", f"{p.T_a:.6g} J", share(p.T_a))
    summary.add_row("rank of A", f"{p.rank} of {np.atleast_2d(data['A']).shape[0]} rows", "")
    if imp is not None:
        summary.add_row("energy lost in impact", f"{imp.energy_lost:.6g} J",
                        share(imp.energy_lost))
    console.print(summary)
    vel = Table(title="Velocities", show_header=True)
    for col in ("coordinate", "v", "v_c", "v_a"):
        vel.add_column(col, justify="right")
    if imp is not None:
        vel.add_column("v+ (after impact)", justify="right")
    for i, name in enumerate(names):
        row = [str(name), f"{data['v'][i]:.6g}", f"{p.v_c[i]:.6g}", f"{p.v_a[i]:.6g}"]
        if imp is not None:
            row.append(f"{imp.v_plus[i]:.6g}")
        vel.add_row(*row)
    console.print(vel)
