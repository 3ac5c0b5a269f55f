"""``roverimpact energy SCENARIO.toml``: effective kinetic energy of an impact scenario."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import typer

from ._app import app, bold, compile_ahead, console, new_table, print_json


def _peak_force(sc, e):
    """Predicted peak force [N] if the scenario gives a contact law and contact is installed."""
    if sc.contact_law is None or importlib.util.find_spec("roverimpact.contact") is None:
        return None
    if not (e.T_c_minus > 0 and e.v_n > 0):
        return 0.0
    from ..contact import get_law, peak_force

    cl = sc.contact_law
    kw = {k: v for k, v in (("e", cl.e), ("n", cl.n)) if v is not None}
    return float(peak_force(float(e.T_c_minus), float(e.v_n), get_law(cl.name, k=cl.k, **kw)))


@app.command("energy")
def energy_cmd(
    file: Path = typer.Argument(..., help="Scenario TOML file (see docs/models.md)."),
    as_json: bool = typer.Option(False, "--json", help="Print machine-readable JSON."),
) -> None:
    """T, T_c^-, T_a, effective mass along the impact normal, approach speed, peak force."""
    from .._kernels.partition import partition_kernel
    from ..models._assemble import _evaluate_one

    compile_ahead(_evaluate_one)  # needed first: in the background on a fresh install
    from ..scenario import ImpactSetup, load_scenario
    from ..scenario.build import scenario_model

    sc = load_scenario(file)
    model = scenario_model(sc)  # a bad file or model stops before the compile (ms)
    compile_ahead(now=(partition_kernel,), small=True)  # meanwhile
    setup = ImpactSetup.from_scenario(sc, model=model)
    e = setup.partition()
    f_max = _peak_force(sc, e)
    out = e.as_dict() | {
        "labels": list(setup.labels), "contact_point": setup.contact_point,
        "normal": setup.normal, "peak_force": f_max,
        "constraints": sc.constraints if isinstance(sc.constraints, str) else "list",
        "released": [lab for lab in setup.candidate_labels if lab not in setup.labels],
    }
    # a contact whose normal row holds but whose no-slip rows do not slides: it has not
    # released (contacts.ground = "coulomb")
    held_normal = {lab.rpartition(":")[0] for lab in setup.labels if lab.endswith(":normal")}
    out["sliding"] = [lab for lab in out["released"]
                      if lab.endswith((":long", ":lat")) and lab.rpartition(":")[0] in held_normal]
    if as_json:
        print_json(out)
        return
    if sc.description:
        console.print(bold(sc.description))
    t = new_table(f"Impact energy of {file.name} ({setup.model.name})", "quantity", "value")
    t.add_row("T (total)", f"{e.T:.6g} J")
    t.add_row("T_c^- (effective)", f"{e.T_c_minus:.6g} J")
    t.add_row("T_a (admissible)", f"{e.T_a:.6g} J")
    t.add_row("m_eff along n (other rows held)", f"{e.m_eff:.6g} kg")
    t.add_row("m_eff along n (obstacle row alone)", f"{e.m_eff_free:.6g} kg")
    t.add_row("v_n (normal approach speed)", f"{e.v_n:.6g} m/s")
    if f_max is not None:
        from ..contact import law_class

        # the registry's name: a file's "hunt_crossley" or "Hunt-Crossley" is hunt-crossley
        t.add_row(f"peak force ({law_class(sc.contact_law.name).name})", f"{f_max:.6g} N")
    t.add_row("active rows / rank", f"{len(setup.labels)} / {e.rank}")
    console.print(t)
    if not e.v_n > 0:
        console.print(f"no impact: the contact does not approach the face (v_n = {e.v_n:.3g} "
                      "m/s), so T_c^- = 0", highlight=False)
    console.print("rows: " + ", ".join(setup.labels), highlight=False)
    if sc.constraints == "auto":
        console.print("contacts that hold through the impact (auto): "
                      + ", ".join(setup.labels), highlight=False)
        released = [lab for lab in out["released"] if lab not in out["sliding"]]
        console.print("contacts that release: " + (", ".join(released) or "none"),
                      highlight=False)
        if out["sliding"]:
            sliding = dict.fromkeys(lab.rpartition(":")[0] for lab in out["sliding"])
            console.print("contacts that hold and slide (no-slip rows not held): "
                          + ", ".join(sliding), highlight=False)
