"""``roverimpact partition FILE``: energy partition of a system given as M, A, v."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from ._app import app, bold, console, new_table, one_format, print_csv, print_json


@app.command("partition")
def partition_cmd(
    file: Path = typer.Argument(..., help="A .npz or .toml file with arrays M, A and v."),
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable JSON."),
    as_csv: bool = typer.Option(False, "--csv", help="Print the velocities (one row per "
                                "coordinate) as CSV."),
) -> None:
    """Split the kinetic energy of (M, A, v) into T_c and T_a and show the impact map.

    Rows ``persistent`` (held through the impact) join A in the partition. If the file
    gives a ``restitution``, the impulsive impact of the rows of A is shown too.
    """
    one_format(as_json, as_csv)
    from .._io import load_system
    from ..energy import partition
    from ..exceptions import InputError
    from ..impulse import impulsive_impact

    data = load_system(file)
    B = data.get("persistent")
    if (np.ndim(data["M"]) > 2 or np.ndim(data["A"]) > 2 or np.ndim(data["v"]) > 1
            or np.ndim(B) > 2):
        raise typer.BadParameter("partition FILE takes one system, not a batch", param_hint="FILE")
    held = data["A"]           # the rows of the partition
    if B is not None and np.size(B):
        # T_c^- is the energy in the subspace of every row held at the impact (theory.md,
        # section 3): with B v- = 0 and e = 0 the impact removes exactly this T_c
        A2, B2 = np.atleast_2d(data["A"]), np.atleast_2d(B)
        if A2.shape[-1] != B2.shape[-1]:
            raise InputError(f"persistent has {B2.shape[-1]} columns, A has {A2.shape[-1]}: "
                             "each row takes one entry per coordinate of v")
        held = np.concatenate([A2, B2])
    p = partition(data["M"], held, data["v"])
    imp = None
    if "restitution" in data:
        imp = impulsive_impact(data["M"], data["A"], data["v"], data["restitution"], B)
    names = data.get("names") or [f"q{i}" for i in range(len(p.v_c))]
    if as_json:
        out = {
            "T": p.T, "T_c": p.T_c, "T_a": p.T_a, "rank": p.rank, "v_c": p.v_c, "v_a": p.v_a,
        }
        if imp is not None:
            out |= {"v_plus": imp.v_plus, "impulse": imp.impulse,
                    "energy_lost": imp.energy_lost}
        print_json(out)
        return
    header = ["coordinate", "v", "v_c", "v_a"] + (["v_plus"] if imp is not None else [])
    rows = [[str(name), data["v"][i], p.v_c[i], p.v_a[i]]
            + ([imp.v_plus[i]] if imp is not None else []) for i, name in enumerate(names)]
    if as_csv:
        print_csv(header, rows)
        return
    if "description" in data:
        console.print(bold(data["description"]))
    summary = new_table(f"Kinetic-energy partition of {file.name}", "quantity", "value",
                        "share")
    share = (lambda x: f"{100 * x / p.T:.1f} %") if p.T > 0 else (lambda x: "-")
    summary.add_row("T (total)", f"{p.T:.6g} J", share(p.T))
    summary.add_row("T_c (constrained, effective)", f"{p.T_c:.6g} J", share(p.T_c))
    summary.add_row("T_a (admissible)", f"{p.T_a:.6g} J", share(p.T_a))
    n_rows = np.atleast_2d(held).shape[0]
    summary.add_row("rank of A" if held is data["A"] else "rank of A and persistent",
                    f"{p.rank} of {n_rows} rows", "")
    if imp is not None:
        summary.add_row("energy lost in impact", f"{imp.energy_lost:.6g} J",
                        share(imp.energy_lost))
    console.print(summary)
    vel = new_table("Velocities (units of v)", "coordinate", "v", "v_c", "v_a",
                    *(["v+ (after impact)"] if imp is not None else []))
    for r in rows:
        vel.add_row(r[0], *(f"{x:.6g}" for x in r[1:]))
    console.print(vel)
