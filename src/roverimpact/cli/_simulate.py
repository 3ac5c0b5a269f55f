"""``roverimpact simulate FILE -o OUTDIR``: compliant-contact impact run (the reference F_max)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import typer
from rich.table import Table

from ._app import app, console


@app.command("simulate")
def simulate_cmd(
    file: Path = typer.Argument(..., help="Scenario TOML with [model] and a [simulation] table."),
    outdir: Path = typer.Option(Path("simulate_out"), "-o", "--outdir",
                                help="Directory for the table, summary and plot."),
    fmt: str = typer.Option("parquet", "--format", help="Table format: parquet or csv."),
    plot: bool = typer.Option(True, "--plot/--no-plot", help="Write force_vs_time.png."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Drive the rover into the obstacle with compliant contact; report F_max and T_c^-."""
    from ..simulate import simulate_impact
    from ..simulate._files import load_simulation
    from ..simulate._run import build_system

    if fmt not in ("parquet", "csv"):
        raise typer.BadParameter("use parquet or csv", param_hint="--format")
    model, cfg = load_simulation(file)
    result = simulate_impact(model, cfg)
    outdir.mkdir(parents=True, exist_ok=True)
    table = result.write(outdir / f"history.{fmt}")
    summary = {k: (float(v) if not isinstance(v, (str, bool)) else v)
               for k, v in result.summary().items()}
    summary |= {"A_rows": result.A_rows, "stats": result.stats,
                "q_minus": result.q_minus.tolist(), "v_minus": result.v_minus.tolist()}
    (outdir / "summary.json").write_text(json.dumps(summary, indent=2))
    (outdir / "config.json").write_text(cfg.model_dump_json(indent=2))
    shutil.copyfile(file, outdir / Path(file).name)
    if plot:
        from ..simulate.plots import plot_force_history

        law = build_system(model, cfg).planes[-1].law
        plot_force_history(result, outdir / "force_vs_time.png", law=law,
                           title=f"{model.name}: beta = {cfg.beta_deg:g} deg, "
                                 f"u = {cfg.speed:g} m/s")
    if as_json:
        console.print_json(json.dumps(summary))
        return
    t = Table(title=f"Compliant impact of {model.name} ({file.name})")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_row("first contact", result.contact_wheel)
    t.add_row("F_max (sum of obstacle contacts)", f"{result.F_max_total:.6g} N")
    for k, v in result.F_max.items():
        if v > 0:
            t.add_row(f"  F_max {k}", f"{v:.6g} N")
            t.add_row(f"  impulse {k}", f"{result.impulse[k]:.6g} N s")
    t.add_row("contact duration", f"{1e3 * result.contact_duration:.4g} ms"
              + ("" if result.separated else " (no separation before t_after)"))
    t.add_row("normal approach speed v_n", f"{result.v_n:.6g} m/s")
    t.add_row("T_c^- (effective kinetic energy)", f"{result.T_c_minus:.6g} J")
    t.add_row("m_eff (obstacle normal)", f"{result.m_eff:.6g} kg")
    t.add_row("T before / after", f"{result.T_minus:.6g} / {result.T_plus:.6g} J")
    t.add_row("integrator", f"{result.stats['steps']} steps, {result.stats['nfev']} evaluations")
    console.print(t)
    console.print(f"wrote {table}, {outdir / 'summary.json'}"
                  + (f", {outdir / 'force_vs_time.png'}" if plot else ""))
