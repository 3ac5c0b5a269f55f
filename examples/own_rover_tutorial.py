"""Every number of docs/tutorial-own-rover.md: your own rover, as written.

Part 1: the Sawppy-type rocker-bogie URDF (examples/models/sawppy_like.urdf) with its
scenario examples/sawppy_like_beta.toml (floating base, six wheels declared by link,
steering locked, two turnbuckle ball joints closed as point loops) and the study
examples/study_sawppy_beta.toml. Part 2: the MJCF rover (examples/mjcf_rover.xml) with
examples/mjcf_rover_beta.toml (wheels declared by geom and by body) and
examples/study_mjcf_rover_beta.toml.

    python examples/own_rover_tutorial.py             # the numbers (10 to 15 s: two studies
                                                      # with simulation)
    python examples/own_rover_tutorial.py --figures   # also docs/img/tutorial_sawppy_beta45.png,
                                                      # tutorial_sawppy_beta.png,
                                                      # tutorial_mjcf_rover_beta.png
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin

import roverimpact as ri
from roverimpact.models.joints import joint_value, set_joint_value
from roverimpact.scenario import ImpactSetup, load_scenario
from roverimpact.scenario.build import scenario_model

HERE = Path(__file__).resolve().parent
IMG = HERE.parent / "docs" / "img"
SAWPPY = HERE / "sawppy_like_beta.toml"
MJCF = HERE / "mjcf_rover_beta.toml"
#: the coordinates the two turnbuckle loops determine, given the left rocker
DEPENDENT = ("brace_joint", "turnbuckle_left_yaw", "turnbuckle_left_pitch",
             "turnbuckle_right_yaw", "turnbuckle_right_pitch", "rocker_right_joint")


def close_loops(mbm, q, theta_left: float, *, tol: float = 1e-14) -> np.ndarray:
    """``q`` with the left rocker at ``theta_left`` [rad] and the brace, turnbuckles and
    right rocker moved so that both turnbuckle loops close (Newton on the loop residual,
    the six dependent joint angles as unknowns)."""
    q = set_joint_value(mbm, q, "rocker_left_joint", theta_left)
    cols = [mbm.model.joints[mbm.model.getJointId(n)].idx_v for n in DEPENDENT]
    for _ in range(50):
        phi, J = mbm.loop_closure(q)
        if np.max(np.abs(phi)) < tol:
            return q
        step = np.linalg.solve(J[:, cols], -phi)
        for name, d in zip(DEPENDENT, step, strict=True):
            q = set_joint_value(mbm, q, name, joint_value(mbm, q, name) + d)
    raise RuntimeError("the turnbuckle loops did not close")


def massless_rod_scenario(sc, folder: Path):
    """The same rover with each turnbuckle as a massless rod: a copy of the URDF without
    the turnbuckle links, and a distance loop (length from the configuration: 0.18 m)
    from each brace end to its rocker tab."""
    tree = ET.parse(sc.model.file)
    root = tree.getroot()
    for el in list(root):
        if el.get("name", "").startswith("turnbuckle_"):
            root.remove(el)
    urdf = folder / "sawppy_like_rods.urdf"
    tree.write(urdf)
    loops = [{"name": f"rod_{side}", "kind": "distance", "frame_a": "brace",
              "point_a": [0.0, y, 0.0], "frame_b": f"rocker_{side}",
              "point_b": [0.12, -0.02 if y > 0 else 0.02, 0.10]}
             for side, y in (("left", 0.15), ("right", -0.15))]
    raw = sc.model_dump(mode="json", exclude_none=True)
    raw["model"]["file"] = str(urdf)
    raw["contacts"]["loops"] = loops
    return ri.Scenario.model_validate(raw)


def peak_force(sc, e) -> float:
    """The Hunt-Crossley peak force predicted from T_c^- and v_n (as `roverimpact energy`)."""
    from roverimpact.contact import peak_force as pf

    return float(pf(float(e.T_c_minus), float(e.v_n), sc.contact_law.to_law()))


def run_study(file: Path, out: Path):
    """`roverimpact sweep FILE -o OUT`: the results table and the agreement statistics."""
    from roverimpact.report.html import build_report
    from roverimpact.studies import agreement
    from roverimpact.studies import run_study as run

    res = run(file, out, overwrite=True)
    build_report(out)
    t = res.table
    ok = ~t["contact_whole_window"].astype(bool)
    a = agreement(t.loc[ok, "T_c_minus"], t.loc[ok, "F_max"], n_boot=1000, seed=0)
    return t, ok, a


def part1(figures: bool, work: Path) -> None:
    print("=== Part 1: Sawppy-like URDF rover ===")
    sc = load_scenario(SAWPPY)
    mbm = scenario_model(sc)
    model = mbm.model
    n_cont = sum(model.joints[j].nq == 2 for j in range(2, model.njoints))
    print(f"joints {model.njoints - 1} (root_joint + {model.njoints - 2} of the file, "
          f"{n_cont} of them continuous), nq = {model.nq}, nv = {model.nv}; MuJoCo M(q) "
          f"check: {mbm.params['mujoco_check']}")
    urdf_mass = sum(float(m.get("value")) for m in ET.parse(sc.model.file).getroot().iter("mass"))
    tb = [model.inertias[model.getJointId(f"turnbuckle_{s}_pitch")].mass for s in ("left", "right")]
    print(f"total mass {sum(Y.mass for Y in model.inertias):.2f} kg (URDF <mass> sum "
          f"{urdf_mass:.2f} kg); turnbuckles {tb[0]:.2f} + {tb[1]:.2f} kg in the tree")
    setup = ImpactSetup.from_scenario(sc)
    phi, _ = mbm.loop_closure(setup.q)
    spins = [float(setup.v[model.joints[model.getJointId(w.spin)].idx_v]) for w in mbm.wheels]
    print(f"loop residual at the scenario's configuration {np.max(np.abs(phi)):.1e} m; "
          f"wheel spin rates {min(spins):g}..{max(spins):g} rad/s (u / r = "
          f"{sc.velocity.u / 0.06:g})")
    e = setup.partition()
    locks = [lab for lab in setup.labels if lab.startswith("lock:")]
    print(f"beta = 45 deg (as `roverimpact energy`): T = {e.T:.6g} J, T_c^- = "
          f"{e.T_c_minus:.6g} J, T_a = {e.T_a:.6g} J, m_eff = {e.m_eff:.6g} kg (alone "
          f"{e.m_eff_free:.6g} kg), v_n = {e.v_n:.6g} m/s, F_pred = {peak_force(sc, e):.6g} N; "
          f"{len(setup.labels)} active rows of "
          f"{len(setup.candidate_labels)} ({len(locks)} steering locks), released: "
          + ", ".join(lab for lab in setup.candidate_labels if lab not in setup.labels))

    betas = np.arange(0.0, 91.0, 5.0)
    sw = ri.sweep_energy(setup, np.deg2rad(betas))
    k = int(np.argmax(sw.T_c_minus))
    print("T_c^- vs beta: " + ", ".join(f"{b:g}: {t:.4f}" for b, t in
                                         zip(betas[::3], sw.T_c_minus[::3], strict=True)))
    print(f"largest T_c^- {sw.T_c_minus[k]:.4f} J at beta = {betas[k]:g} deg "
          f"({100 * sw.T_c_minus[k] / sw.T[k]:.0f} % of T); at 90 deg {sw.T_c_minus[-1]:.4f} J")

    # exact, not linearised: close the loops with the left rocker up by 0.2 rad
    qc = close_loops(mbm, setup.q, 0.2)
    th_r = joint_value(mbm, qc, "rocker_right_joint")
    q_lin = set_joint_value(mbm, qc, "rocker_right_joint", -0.2)
    print(f"left rocker +0.2 rad: right rocker {th_r:.5f} rad (linear coupling: -0.2), brace "
          f"{joint_value(mbm, qc, 'brace_joint'):.5f} rad; residual "
          f"{np.max(np.abs(mbm.loop_closure(qc)[0])):.1e} m, with the linear coupling "
          f"{1e3 * np.max(np.abs(mbm.loop_closure(q_lin)[0])):.1f} mm")

    # the turnbuckles as massless rods (distance loops), as a hand-linearised model had them
    rods = massless_rod_scenario(sc, work)
    e_rod = ri.energy_of(rods)
    change = 100 * (e_rod.T_c_minus / e.T_c_minus - 1)
    print(f"turnbuckles as massless rods (distance loops): T_c^- = {e_rod.T_c_minus:.5f} J "
          f"vs {e.T_c_minus:.5f} J with their 0.24 kg ({change:+.2f} %)")

    # why ground = "normal": no-slip rows of three wheels in line
    for ground, mu in (("noslip", None), ("normal", None), ("coulomb", 0.5)):
        c = sc.contacts.model_copy(update={"ground": ground, "mu": mu})
        s_g = ImpactSetup.from_scenario(sc.model_copy(update={"contacts": c}))
        e_g = s_g.partition()
        rng = np.random.default_rng(0)
        out = []
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ri.exceptions.HeldRowsWarning)
            for _ in range(5):
                q = pin.integrate(model, s_g.q, 1e-6 * rng.standard_normal(model.nv))
                s2 = ImpactSetup.from_state(s_g.model, q, s_g.v, obstacle=sc.obstacle,
                                            contacts=c)
                out.append(float(s2.partition().T_c_minus))
        jammed = sum(w.category is ri.exceptions.HeldRowsWarning for w in caught)
        pulling = sum(w.category is ri.exceptions.PullingContactWarning for w in caught)
        print(f"ground = {ground!r}" + (f", mu = {mu:g}" if mu else "") + f": T_c^- = "
              f"{e_g.T_c_minus:.5f} J (rank {e_g.rank} of {len(s_g.labels)} rows); q moved "
              f"by 1e-6 (5 random steps): {min(out):.5f}..{max(out):.5f} J"
              + (f"; HeldRowsWarning (m_eff above the total mass) in {jammed} of 5"
                 if jammed else "")
              + (f"; PullingContactWarning (a held wheel pulls) in {pulling} of 5"
                 if pulling else ""))

    import time

    t0 = time.perf_counter()
    t, ok, a = run_study(HERE / "study_sawppy_beta.toml", work / "sawppy-results")
    print(f"(the study took {time.perf_counter() - t0:.1f} s)")
    print(f"study: {len(t)} cases, {int((~ok).sum())} whole-window (beta "
          + ", ".join(f"{b:g}" for b in t.loc[~ok, "obstacle.beta_deg"])
          + f" deg) excluded; Spearman {a.spearman.value:.3f}, Kendall {a.kendall.value:.3f} "
          f"(n = {int(ok.sum())}); F_max/F_pred at 45 deg "
          f"{float((t.F_max / t.F_pred)[t['obstacle.beta_deg'] == 45.0].iloc[0]):.2f}")
    if figures:
        from roverimpact.report.draw import draw_setup

        draw_setup(setup, IMG / "tutorial_sawppy_beta45.png")
        shutil.copyfile(work / "sawppy-results" / "figure.png", IMG / "tutorial_sawppy_beta.png")
        print("wrote docs/img/tutorial_sawppy_beta45.png, docs/img/tutorial_sawppy_beta.png")


def part2(figures: bool, work: Path) -> None:
    print("=== Part 2: MJCF rover ===")
    sc = load_scenario(MJCF)
    setup = ImpactSetup.from_scenario(sc)
    mbm = setup.model
    print("wheels: " + "; ".join(f"{w.name}: frame {w.frame}, r = {w.radius:g} m, spin "
                                 f"{w.spin}" for w in mbm.wheels)
          + f"; base {mbm.params['base']['kind']} {mbm.params['base']['joints']}")
    e = setup.partition()
    e_all = ri.energy_of(sc.model_copy(update={"constraints": "all"}))
    print(f"beta = 45 deg (as `roverimpact energy`): T = {e.T:.6g} J, T_c^- = "
          f"{e.T_c_minus:.6g} J, m_eff = {e.m_eff:.6g} kg, v_n = {e.v_n:.6g} m/s, F_pred = "
          f"{peak_force(sc, e):.6g} N; "
          "released: " + ", ".join(lab for lab in setup.candidate_labels
                                   if lab not in setup.labels)
          + f"; rear wheel held (constraints = 'all'): T_c^- = {e_all.T_c_minus:.3f} J")
    betas = np.arange(0.0, 91.0, 5.0)
    sw = ri.sweep_energy(setup, np.deg2rad(betas))
    k = int(np.argmax(sw.T_c_minus))
    print(f"largest T_c^- {sw.T_c_minus[k]:.3f} J at beta = {betas[k]:g} deg")
    t, ok, a = run_study(HERE / "study_mjcf_rover_beta.toml", work / "mjcf-results")
    print(f"study: {len(t)} cases, {int((~ok).sum())} whole-window excluded; Spearman "
          f"{a.spearman.value:.3f}, Kendall {a.kendall.value:.3f} (n = {int(ok.sum())})")
    if figures:
        shutil.copyfile(work / "mjcf-results" / "figure.png", IMG / "tutorial_mjcf_rover_beta.png")
        print("wrote docs/img/tutorial_mjcf_rover_beta.png")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figures", action="store_true", help="also write the docs' figures")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        part1(args.figures, Path(tmp))
        part2(args.figures, Path(tmp))


if __name__ == "__main__":
    main()
