"""MuJoCo with the scenario's own contact laws (engine ``mujoco_laws``, ``contact="laws"``).

MuJoCo computes the rover's dynamics (its mass matrix, bias forces, the loop-closure
equality) and integrates; the laws (Hunt-Crossley on the obstacle and the ground) are
evaluated before every step from MuJoCo's geometry and applied as forces. References:

* 1-DoF body into a Hunt-Crossley wall: the closed-form peak force and restitution of
  the literature (``contact.predict``), which neither engine computes;
* the two rovers, Hunt-Crossley contact: the own engine (Pinocchio dynamics, scipy);
* the refined prediction ``F_pred_refined`` (docs/contact.md) on the rocker-bogie at the
  steep faces where MuJoCo's soft contact (an equivalent spring-damper) misses it by up
  to 12 %: with the same law in MuJoCo the miss is the prediction's own.
"""

from __future__ import annotations

import pytest

pytest.importorskip("mujoco")

from roverimpact._io import read_toml
from roverimpact.contact import get_law, predict
from roverimpact.exceptions import ConfigError
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.simulate import SimulationConfig, initial_state, simulate_impact
from roverimpact.simulate.engines import (
    check_engine,
    engine_name,
    get_engine,
    simulate_impact_mujoco,
    simulate_impact_mujoco_laws,
)
from roverimpact.studies.config import apply_overrides
from roverimpact.studies.evaluate import evaluate_case
from roverimpact.studies.reproduce import builtin_study_path

from .test_engine_mujoco import slider
from .textlines import fitted_lines

HC = {"k": 1e7, "e": 0.5}


@pytest.mark.parametrize("law", [{"k": 1e7, "e": 0.5}, {"k": 1e7, "e": 0.9},
                                 {"name": "hertz", "k": 1e8}])
def test_1dof_slider_matches_the_closed_form(law):
    """MuJoCo's semi-implicit Euler is first order: +0.4 % at the default 100 steps per
    half period (e = 0.5), and the error halves with the step (as the soft contact's)."""
    cfg = SimulationConfig(ground=False, speed=0.3, obstacle=law, t_after=0.05)
    ref = predict(get_law(law.get("name", "hunt-crossley"), k=law["k"], e=law.get("e")),
                  4.0, 0.3)
    errors = []
    for n in (100, 400):
        r = simulate_impact_mujoco_laws(slider(4.0), cfg, steps_per_mode=n)
        assert r.stats["contact"] == "laws" and "applied" in r.stats["force_source"]
        errors.append(abs(r.F_max_total / ref.peak_force - 1.0))
        assert r.contact_duration == pytest.approx(ref.duration, rel=5e-3)
        imp = 4.0 * 0.3 * (1.0 + ref.restitution_achieved)
        assert r.impulse["obstacle_ball"] == pytest.approx(imp, rel=5e-3)
    assert errors[0] < 5e-3 and errors[1] < 1.5e-3 and errors[1] < 0.4 * errors[0]


@pytest.mark.parametrize("name, make, beta", [
    ("rover2d", lambda: rover2d(suspension="rocker"), 60.0),
    ("rocker_bogie", rocker_bogie, 90.0),
])
def test_rovers_agree_with_the_own_engine(name, make, beta):
    """Same laws, two dynamics engines: F_max, duration and the pre-impact T_c^- agree
    (measured 0.01-0.1 %; MuJoCo's soft contact differs by up to 3 % here)."""
    mbm = make()
    cfg = SimulationConfig(speed=0.3, beta_deg=beta, obstacle=HC, t_after=0.05)
    q0, v0 = initial_state(mbm, cfg)
    own = simulate_impact(mbm, cfg, q0=q0, v0=v0)
    mj = simulate_impact_mujoco(mbm, cfg, q0=q0, v0=v0, contact="laws")
    assert mj.F_max_total == pytest.approx(own.F_max_total, rel=5e-3)
    assert mj.contact_duration == pytest.approx(own.contact_duration, rel=5e-3)
    assert mj.T_c_minus == pytest.approx(own.T_c_minus, rel=1e-3)
    assert mj.separated == own.separated
    # every force in the history is the law at the recorded indentation and rate
    h = mj.history
    w = mj.contact_wheel
    on = h[f"obstacle_{w}_delta"].to_numpy() > 0
    assert on.sum() > 50
    assert (h[f"obstacle_{w}_fn"].to_numpy()[~on] == 0).all()


@pytest.mark.parametrize("beta", [80.0, 90.0])
def test_refined_prediction_within_5_percent_of_mujoco_with_the_same_law(beta):
    """DETC2015-47747 Fig. 2 (rocker-bogie, Hunt-Crossley): F_pred_refined against MuJoCo
    running that law, at the steep faces where the soft contact's equivalent spring-damper
    is 5-12 % off (docs/contact.md)."""
    base = read_toml(builtin_study_path("detc2015_fig2_beta"))["base"]
    case = apply_overrides(base, {"obstacle.beta_deg": beta})
    out = evaluate_case(case, simulate=["mujoco_laws", "mujoco"])
    assert not out["not_an_impact"] and not out["contact_whole_window"]
    assert out["F_pred_refined"] / out["F_max"] == pytest.approx(1.0, abs=0.05)
    # the soft contact's own prediction follows that engine (docs/contact.md)
    assert out["F_pred_refined_mujoco"] / out["F_max_mujoco"] == pytest.approx(1.0, abs=0.01)


def test_names_and_bad_input():
    assert engine_name("MuJoCo-Laws") == "mujoco_laws"
    assert get_engine("mujoco_laws") is simulate_impact_mujoco_laws
    rv = rover2d()
    with pytest.raises(ConfigError, match="needs mu = 0"):
        check_engine("mujoco_laws", rv, SimulationConfig(mu=0.3))
    with pytest.raises(ConfigError, match="needs mu = 0"):
        simulate_impact_mujoco_laws(rv, SimulationConfig(mu=0.3))
    with pytest.raises(ConfigError, match="contact must be 'soft'"):
        simulate_impact_mujoco(rv, SimulationConfig(), contact="rigid")
    with pytest.raises(ConfigError, match="terrain"):
        check_engine("mujoco_laws", rv, SimulationConfig(), terrain=True)
    check_engine("mujoco_laws", rv, SimulationConfig())          # frictionless: accepted


# ------------------------------------------------------------------- command line
def test_simulate_cli_with_the_laws_in_mujoco(tmp_path, capsys):
    """``roverimpact simulate FILE --engine mujoco-laws``: the example scenario without its
    friction (Hunt-Crossley obstacle and ground) agrees with the own engine within 0.5 %;
    the table says how the contact was run; the example as it is (mu = 0.3): one error
    line, exit 2, nothing written."""
    import json
    from pathlib import Path

    from roverimpact.cli import main

    example = Path(__file__).resolve().parents[1] / "examples" / "simulate_rover2d.toml"
    text = example.read_text()
    assert "mu = 0.3" in text
    frictionless = tmp_path / "mu0.toml"
    frictionless.write_text(text.replace("mu = 0.3", "mu = 0.0", 1))
    F = {}
    for engine in ("own", "mujoco-laws"):
        assert main(["simulate", str(frictionless), "-o", str(tmp_path / engine), "--json",
                     "--no-plot", "--engine", engine]) == 0
        summary = json.loads(capsys.readouterr().out)
        F[engine] = summary["F_max_total"]
    assert summary["engine"] == "mujoco_laws" and summary["stats"]["contact"] == "laws"
    assert F["mujoco-laws"] == pytest.approx(F["own"], rel=5e-3)
    assert main(["simulate", str(frictionless), "-o", str(tmp_path / "t"), "--no-plot",
                 "--engine", "mujoco_laws"]) == 0
    out = capsys.readouterr().out
    assert "the scenario's, applied as forces" in out
    assert max(map(len, fitted_lines(out))) <= 80

    out_dir = tmp_path / "refused"
    assert main(["simulate", str(example), "-o", str(out_dir), "--engine", "mujoco_laws"]) == 2
    err = capsys.readouterr().err
    assert "needs mu = 0" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not out_dir.exists()


@pytest.mark.parametrize("obstacle, ground", [
    (HC, {"name": "lankarani-nikravesh", "k": 2e7, "e": 0.6}),     # one family, one call
    ({"name": "kelvin-voigt", "k": 1e6, "c": 2000.0}, {"k": 1e7, "e": 0.2}),
    ({"name": "hertz", "k": 1e7}, {"name": "kelvin-voigt", "k": 1e6, "c": 2000.0}),
])
def test_recorded_forces_are_the_laws_at_pinocchios_state(obstacle, ground):
    """Every normal force of the history (planes x wheels, each record) is the law at the
    record's state as the own engine's ContactSystem (Pinocchio's kinematics) evaluates it:
    the engine's per-step evaluation from MuJoCo's geometry (centre velocities from
    ``cvel``, several laws and planes, family laws evaluated together) against an
    independent one, to the rounding of the two kinematics."""
    import dataclasses

    import numpy as np

    from roverimpact.simulate import build_system

    mbm = rover2d(suspension="rocker")
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle=obstacle, ground_contact=ground,
                           t_after=0.02)
    q0, v0 = initial_state(mbm, cfg)
    sys = build_system(mbm, cfg)
    n = sys.planes[-1].n
    x0 = (1e-3 - float(np.min(sys.wheel_centres(q0) @ n - sys.radii))) / n[0] * -1.0
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle=obstacle, ground_contact=ground,
                           t_after=0.02, obstacle_x=x0)
    r = simulate_impact_mujoco_laws(mbm, cfg, q0=q0, v0=v0)
    obst = dataclasses.replace(sys.planes[-1], p0=np.array([x0, 0.0, 0.0]))
    ref = dataclasses.replace(sys, planes=[*sys.planes[:-1], obst])
    h = r.history
    v_i = [p.v_i for p in ref.planes[:-1]] + [r.v_n]
    names = [(p.name, w.name) for p in ref.planes for w in mbm.wheels]
    fn = h[[f"{p}_{w}_fn" for p, w in names]].to_numpy()
    Q = h[[f"q_{j}" for j in range(ref.nq)]].to_numpy()
    V = h[[f"v_{j}" for j in range(ref.nv)]].to_numpy()
    checked = 0
    for i in range(0, len(h), 7):
        cs = ref.contacts(Q[i], V[i], v_i)
        expect = np.where(cs.delta > 0, cs.f_n, 0.0).ravel()
        # a Kelvin-Voigt pair at its first touch jumps to c v: compare away from delta = 0
        sure = np.abs(cs.gap.ravel()) > 1e-9
        assert fn[i][sure] == pytest.approx(expect[sure], rel=1e-6, abs=1e-6)
        checked += int((expect[sure] > 0).sum())
    assert checked > 20 and (fn[:, -len(mbm.wheels):] > 0).any()
