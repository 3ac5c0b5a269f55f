"""``roverimpact simulate FILE -o OUTDIR``: compliant-contact impact run (the reference F_max)."""

from __future__ import annotations

import shutil
from pathlib import Path

import typer

from .._io import staged_folder
from ._app import (
    app,
    check_output,
    compile_ahead,
    console,
    json_text,
    new_table,
    print_json,
    print_paths,
)

#: What a simulate run writes, by exact name (the scenario copied as scenario.toml, its
#: path in summary.json): a folder holding these and summary.json + config.json is a
#: previous run, replaced by the next one. By name, not "*.toml": a user's own .toml
#: file in that folder was deleted by the next run
SIMULATE_FILES = ("history.parquet", "history.csv", "summary.json", "config.json",
                  "force_vs_time.png", "scenario.toml")


def _compile_ahead() -> None:
    """On a fresh install: Lemke's impact kernel (the active set at first contact, 6.6 s
    of compile) in a second process, the partition kernel here at once (``compile_ahead``):
    a first ``roverimpact simulate examples/simulate_rover2d.toml`` took 10.6 s in one
    process, 8.0 s so (benchmarks/bench_startup.py --full)."""
    from .._kernels.lemke import impact_kernel
    from .._kernels.partition import partition_kernel

    compile_ahead(impact_kernel, now=(partition_kernel,), small=True)


@app.command("simulate")
def simulate_cmd(
    file: Path = typer.Argument(..., help="Scenario TOML (its [simulation] table is optional)."),
    outdir: Path = typer.Option(Path("simulate_out"), "-o", "--outdir",
                                help="Directory for the table, summary and plot."),
    fmt: str = typer.Option("parquet", "--format", help="Table format: parquet or csv."),
    plot: bool = typer.Option(True, "--plot/--no-plot", help="Write force_vs_time.png."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    engine: str = typer.Option("own", "--engine", help="Simulator: own (roverimpact's, the "
                               "reference), mujoco (MuJoCo, its soft contact) or mujoco_laws "
                               "(MuJoCo's dynamics, the scenario's contact laws)."),
) -> None:
    """Drive the rover into the obstacle with compliant contact; report F_max and T_c^-."""
    from .._engines import engine_name
    from ..scenario import load_scenario
    from ..scenario.build import scenario_model
    from ..simulate import SimulationConfig, simulate_scenario
    from ..simulate.run import build_system

    engine = engine_name(engine)
    in_mujoco = engine.startswith("mujoco")
    if fmt not in ("parquet", "csv"):
        raise typer.BadParameter("use parquet or csv", param_hint="--format")
    check_output(outdir, folder=True)
    sc = load_scenario(file)
    with staged_folder(outdir, SIMULATE_FILES, ("summary.json", "config.json"),
                       "simulate") as work:
        cfg = SimulationConfig.from_scenario(sc, where=str(file))
        model = scenario_model(sc)  # both checks (9 ms for the example): before the compile
        if not in_mujoco:
            build_system(model, cfg)  # the wheels named (10 ms, no kernel)
        _compile_ahead()
        result = simulate_scenario(sc, model=model, where=str(file), engine=engine)
        table = outdir / result.write(work / f"history.{fmt}").name
        summary = dict(result.summary())
        summary |= {"engine": engine, "contact_whole_window": not result.separated,
                    "t_after": cfg.t_after, "A_rows": result.A_rows, "stats": result.stats,
                    "q_minus": result.q_minus, "v_minus": result.v_minus,
                    "scenario": str(Path(file).resolve())}
        (work / "summary.json").write_text(json_text(summary))
        (work / "config.json").write_text(json_text(cfg.model_dump(mode="json")
                                                    | {"engine": engine}))
        shutil.copyfile(file, work / "scenario.toml")
        if plot:
            from ..report.simulation import plot_force_history

            law = build_system(model, cfg).planes[-1].law
            plot_force_history(result, work / "force_vs_time.png", law=law,
                               title=f"{model.name}: beta = {cfg.beta_deg:g} deg, "
                                     f"u = {cfg.speed:g} m/s"
                                     + (" (MuJoCo)" if in_mujoco else ""))
    if as_json:
        print_json(summary)
        return
    t = new_table(f"Compliant impact of {model.name} ({file.name}"
                  + (", MuJoCo)" if in_mujoco else ")"), "quantity", "value")
    t.add_row("first contact", result.contact_wheel)
    t.add_row("F_max (sum of obstacle contacts)", f"{result.F_max_total:.6g} N")
    for k, v in result.F_max.items():
        if v > 0:
            t.add_row(f"  F_max {k}", f"{v:.6g} N")
            t.add_row(f"  impulse {k}", f"{result.impulse[k]:.6g} N s")
    t.add_row("contact duration", f"{1e3 * result.contact_duration:.4g} ms")
    t.add_row("contact ended (wheel left the face)",
              "yes" if result.separated else "no: whole window")
    t.add_row("normal approach speed v_n", f"{result.v_n:.6g} m/s")
    t.add_row("T_c^- (effective kinetic energy)", f"{result.T_c_minus:.6g} J")
    t.add_row("m_eff along n (obstacle row alone)", f"{result.m_eff:.6g} kg")
    t.add_row("T before / after", f"{result.T_minus:.6g} / {result.T_plus:.6g} J")
    st = result.stats
    if in_mujoco:
        t.add_row("engine", f"MuJoCo, {st['steps']} steps of {1e6 * st['timestep']:.3g} us")
    if engine == "mujoco_laws":
        t.add_row("contact laws in MuJoCo", "the scenario's, applied as forces")
    elif engine == "mujoco":
        mp = st["mapping"]
        exact = str(mp["obstacle"]).startswith("kelvin-voigt")
        t.add_row("obstacle law in MuJoCo", f"Kelvin-Voigt k = {mp['obstacle_k']:.4g} N/m, "
                  f"c = {mp['obstacle_c']:.4g} N s/m ({'exact' if exact else 'equivalent'})")
    else:
        t.add_row("integrator", f"{st['steps']} steps, {st['nfev']} evaluations")
    notes = []
    if engine == "mujoco" and cfg.mu > 0.0:
        notes.append("friction (mu > 0) is approximate in the MuJoCo engine: see "
                     "docs/simulate.md.")
    if not result.separated:
        notes.append("whole window: the contact had not ended when the simulation stopped "
                     f"(t_after = {cfg.t_after:g} s after first contact), so F_max is the "
                     "largest force in the window, not the peak of a finished impact.")
    t.caption = " ".join(notes) or None
    console.print(t)
    written = [table] + [outdir / n for n in ("summary.json", "config.json", "scenario.toml")]
    if plot:
        written.append(outdir / "force_vs_time.png")
    print_paths("wrote", *written)
