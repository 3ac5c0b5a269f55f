"""MuJoCo as the second engine through the user-facing tools, and the baseline indicators.

- ``roverimpact simulate --engine mujoco``: the same scenario file in MuJoCo; with
  Kelvin-Voigt contacts (mapped exactly) F_max equals the own engine's within 1 %, for a
  built-in rover and for an MJCF file model; a model MuJoCo cannot take, an unknown engine:
  one error line, exit 2, nothing written.
- Studies: ``simulate = "mujoco"`` / ``["own", "mujoco"]``; the MuJoCo column equals a
  direct ``simulate_impact_mujoco`` run and agrees with the own engine within 1 %.
- Baselines: ``T_c_obstacle`` against the closed form of the rigid body and against the
  core's partition with the obstacle row alone; ``m_total`` against MuJoCo's
  ``mj_getTotalmass`` of the exported model; the statements against tables whose answer
  is known; ``spearman_difference`` against scipy.
- The fixed-v_n study: v_n and m_total are the same in every case, T_c^- is not.
- Trust map with the engine as an axis; experiment baselines against scipy.

(The reproduction's MuJoCo columns are tested in tests/test_study_reproduce.py.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from roverimpact.cli import main

from .textlines import fitted_lines

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"
KV = {"name": "kelvin-voigt", "k": 1.0e6, "c": 2000.0}

SCENARIO_KV = """
[model]
name = "rover2d"
params = { suspension = "rocker" }
[velocity]
u = 0.3
[obstacle]
wheel = "front"
beta_deg = 60.0
[contact_law]
name = "kelvin-voigt"
k = 1.0e6
c = 2000.0
[simulation]
t_after = 0.03
ground_contact = { name = "kelvin-voigt", k = 1.0e6, c = 2000.0 }
springs = { rocker = { k = 50.0, c = 2.0 } }
"""

MJCF_SCENARIO = """
[model]
file = "{file}"
[model.wheels.front]
frame = "front_wheel"
[model.wheels.rear]
frame = "rear_wheel"
[velocity]
u = 0.3
[obstacle]
wheel = "front"
beta_deg = 60.0
[contact_law]
name = "kelvin-voigt"
k = 1.0e6
c = 2000.0
[simulation]
t_after = 0.05
ground_contact = { name = "kelvin-voigt", k = 1.0e6, c = 2000.0 }
"""


def _one_error(capsys, argv) -> str:
    """Run argv: exit 2, nothing on stdout, exactly one 'error:' line on stderr."""
    rc = main(argv)
    out = capsys.readouterr()
    assert rc == 2, out
    assert out.out == ""
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), out.err
    assert "Traceback" not in out.err
    return lines[0]


# ------------------------------------------------------------------- simulate --engine
def test_simulate_cli_mujoco_matches_own_engine_with_kelvin_voigt(tmp_path, capsys):
    scn = tmp_path / "kv.toml"
    scn.write_text(SCENARIO_KV)
    F = {}
    for engine in ("own", "mujoco"):
        out = tmp_path / engine
        assert main(["simulate", str(scn), "-o", str(out), "--engine", engine, "--json",
                     "--no-plot"]) == 0
        summary = json.loads(capsys.readouterr().out)
        assert summary["engine"] == engine
        assert json.loads((out / "summary.json").read_text())["engine"] == engine
        assert json.loads((out / "config.json").read_text())["engine"] == engine
        assert (out / "history.parquet").is_file()
        F[engine] = summary["F_max_total"]
        assert summary["contact_whole_window"] is False
    # independent engines, the same Kelvin-Voigt law (MuJoCo's solref mapped exactly)
    assert F["mujoco"] == pytest.approx(F["own"], rel=0.01)


def test_simulate_cli_mujoco_table_reads_at_80_columns(tmp_path, capsys):
    scn = tmp_path / "kv.toml"
    scn.write_text(SCENARIO_KV)
    assert main(["simulate", str(scn), "-o", str(tmp_path / "o"), "--engine", "MuJoCo",
                 "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert max(map(len, fitted_lines(out))) <= 80 and "…" not in out
    assert "MuJoCo, " in out and "(exact)" in out


def test_mjcf_file_model_runs_in_mujoco(tmp_path):
    """A robot file (the MJCF rover of the examples) goes through the same Pinocchio model
    into MuJoCo; Kelvin-Voigt contact: F_max of both engines within 1 %."""
    from roverimpact.scenario import load_scenario
    from roverimpact.simulate import simulate_scenario

    scn = tmp_path / "mjcf.toml"
    scn.write_text(MJCF_SCENARIO.replace("{file}", str(EX / "mjcf_rover.xml")))
    sc = load_scenario(scn)
    own = simulate_scenario(sc)
    mj = simulate_scenario(sc, engine="mujoco")
    assert mj.stats["engine"] == "mujoco" and own.separated and mj.separated
    assert mj.F_max_total == pytest.approx(own.F_max_total, rel=0.01)
    assert mj.T_c_minus == pytest.approx(own.T_c_minus, rel=1e-3)


def test_unsupported_file_model_and_unknown_engine_are_refused(tmp_path, capsys):
    xml = (EX / "mjcf_rover.xml").read_text().replace('<joint name="wheel_rear"/>',
                                                      '<joint name="wheel_rear" type="ball"/>')
    (tmp_path / "ball.xml").write_text(xml)
    scn = tmp_path / "ball.toml"
    scn.write_text(MJCF_SCENARIO.replace("{file}", str(tmp_path / "ball.xml")))
    out = tmp_path / "out"
    msg = _one_error(capsys, ["simulate", str(scn), "-o", str(out), "--engine", "mujoco"])
    assert "MuJoCo engine cannot run model" in msg and "wheel_rear" in msg
    assert "JointModelSpherical" in msg and not out.exists()
    msg = _one_error(capsys, ["simulate", str(EX / "simulate_rover2d.toml"), "-o", str(out),
                              "--engine", "bullet"])
    assert "unknown simulation engine 'bullet'" in msg and "own, mujoco" in msg
    assert not out.exists()
    msg = _one_error(capsys, ["trust", "--quick", "-o", str(out), "--engine", "own,ode"])
    assert "unknown simulation engine 'ode'" in msg and not out.exists()


# ------------------------------------------------------------------- studies
def _study(simulate, cases=(30.0, 60.0, 90.0)) -> dict:
    return {
        "name": "kv engines", "simulate": simulate,
        "base": {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
                 "velocity": {"u": 0.3}, "obstacle": {"wheel": "front", "beta_deg": 60.0},
                 "contact_law": KV,
                 "simulation": {"t_after": 0.03, "ground_contact": KV,
                                "springs": {"rocker": {"k": 50.0, "c": 2.0}}}},
        "grid": {"obstacle.beta_deg": list(cases)},
    }


def test_study_with_both_engines(tmp_path):
    from roverimpact.scenario import scenario_from_dict
    from roverimpact.scenario.build import configuration, scenario_model
    from roverimpact.simulate import SimulationConfig
    from roverimpact.simulate.engines import simulate_impact_mujoco
    from roverimpact.studies import run_study
    from roverimpact.studies.config import apply_overrides

    st = _study(["own", "MuJoCo"])
    res = run_study(st, tmp_path / "s")
    t = res.table
    assert json.loads((tmp_path / "s" / "manifest.json").read_text())["engines"] == \
        ["own", "mujoco"]
    for col in ("F_max", "F_max_mujoco", "contact_whole_window_mujoco", "sim_error_mujoco",
                "contact_duration_mujoco", "T_c_minus_sim_mujoco"):
        assert col in t, col
    assert (t["sim_error_mujoco"] == "").all() and res.failures.empty
    np.testing.assert_allclose(t["F_max_mujoco"], t["F_max"], rtol=0.01)
    # the column is MuJoCo's F_max of that scenario, as a direct run gives it
    sc = scenario_from_dict(apply_overrides(st["base"], {"obstacle.beta_deg": 90.0}))
    mbm = scenario_model(sc)
    direct = simulate_impact_mujoco(mbm, SimulationConfig.from_scenario(sc),
                                    q0=configuration(mbm, sc.configuration))
    assert t["F_max_mujoco"].iloc[-1] == pytest.approx(direct.F_max_total, rel=1e-9)


def test_study_mujoco_alone_is_its_reference(tmp_path):
    from roverimpact.studies import run_study

    t = run_study(_study("mujoco", cases=(45.0,)), tmp_path / "m").table
    assert "F_max" in t and "F_max_mujoco" not in t and "F_max_own" not in t
    t2 = run_study(_study(True, cases=(45.0,)), tmp_path / "o").table
    assert t["F_max"].iloc[0] == pytest.approx(t2["F_max"].iloc[0], rel=0.01)
    assert t["F_max"].iloc[0] != t2["F_max"].iloc[0]          # two engines, not one


@pytest.mark.parametrize("value, match", [
    ('"bullet"', "unknown simulation engine 'bullet'"),
    ('["own", "own"]', "lists an engine twice"),
    ("[]", "an empty list"),
])
def test_study_bad_engine(tmp_path, capsys, value, match):
    text = (EX / "study_rigid_body.toml").read_text()
    (tmp_path / "s.toml").write_text(f"simulate = {value}\n" + text)
    out = tmp_path / "out"
    msg = _one_error(capsys, ["sweep", str(tmp_path / "s.toml"), "-o", str(out)])
    assert match in msg and "simulate" in msg
    assert not (out / "results.parquet").exists()


def test_study_refuses_a_model_mujoco_cannot_take_before_any_work(tmp_path, capsys):
    xml = (EX / "mjcf_rover.xml").read_text().replace('<joint name="wheel_rear"/>',
                                                      '<joint name="wheel_rear" type="ball"/>')
    (tmp_path / "ball.xml").write_text(xml)
    import tomllib

    base = tomllib.loads(MJCF_SCENARIO.replace("{file}", str(tmp_path / "ball.xml")))
    import tomli_w

    (tmp_path / "s.toml").write_text(tomli_w.dumps(
        {"name": "ball", "simulate": "mujoco", "base": base,
         "grid": {"obstacle.beta_deg": [30.0, 60.0]}}))
    msg = _one_error(capsys, ["sweep", str(tmp_path / "s.toml"), "-o", str(tmp_path / "o")])
    assert "MuJoCo engine cannot run model" in msg
    assert not (tmp_path / "o" / "results.parquet").exists()


# ------------------------------------------------------------------- baselines
def test_baselines_of_the_rigid_body_against_its_closed_form():
    """The planar rigid body (one contact row): T_c^- with the obstacle row only *is* T_c^-,
    m_eff_free its closed-form effective mass, m_total its mass."""
    from roverimpact.studies.evaluate import evaluate_case

    m, I, h, l = 20.0, 1.0, 0.3, 0.4
    p = {"mass": m, "inertia": I, "com_height": h, "lever": l}
    for beta in (20.0, 55.0, 90.0):
        out = evaluate_case({"model": {"name": "rigid_body", "params": p},
                             "velocity": {"u": 0.5},
                             "obstacle": {"frame": "contact", "beta_deg": beta}})
        b = math.radians(beta)    # models/rigid_body.py: 1/m_eff = 1/m + (h sb - l cb)^2/I
        m_cf = 1.0 / (1.0 / m + (h * math.sin(b) - l * math.cos(b)) ** 2 / I)
        assert out["m_total"] == pytest.approx(20.0, rel=1e-12)
        assert out["m_eff_free"] == pytest.approx(m_cf, rel=1e-9)
        assert out["T_c_obstacle"] == pytest.approx(out["T_c_minus"], rel=1e-9)
        assert out["T_n_total"] == pytest.approx(0.5 * 20.0 * out["v_n"] ** 2, rel=1e-12)


def test_baselines_of_a_rover_against_the_core_and_mujoco(tmp_path):
    """rover2d (rocker): T_c_obstacle = partition of the obstacle row alone (the core's
    kernel, not the effective-mass path), m_total = MuJoCo's total mass of the exported
    model, and T_c^- >= T_c_obstacle (more rows held, more constrained energy)."""
    import mujoco

    from roverimpact import partition
    from roverimpact.models.export_mjcf import export_mjcf
    from roverimpact.scenario import ImpactSetup, scenario_from_dict
    from roverimpact.studies.evaluate import evaluate_case

    scn = {"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
           "velocity": {"u": 0.5}, "obstacle": {"wheel": "front", "beta_deg": 50.0}}
    out = evaluate_case(scn)
    setup = ImpactSetup.from_scenario(scenario_from_dict(scn))
    a = setup.A[setup.obstacle_row][None, :]
    T1 = float(partition(setup.M, a, setup.v).T_c)
    assert out["T_c_obstacle"] == pytest.approx(T1, rel=1e-9)
    assert out["T_c_minus"] >= T1 - 1e-12
    path = export_mjcf(setup.model, tmp_path / "rv.xml")
    m = mujoco.MjModel.from_xml_path(str(path))
    assert out["m_total"] == pytest.approx(mujoco.mj_getTotalmass(m), rel=1e-12)


def test_spearman_difference_against_scipy():
    from roverimpact.studies.stats import spearman_difference

    rng = np.random.default_rng(3)
    y = rng.normal(size=40)
    x1 = y + 0.3 * rng.normal(size=40)
    x2 = y + 1.5 * rng.normal(size=40)
    d = spearman_difference(x1, x2, y, n_boot=500, seed=1)
    ref = sps.spearmanr(x1, y).statistic - sps.spearmanr(x2, y).statistic
    assert d.value == pytest.approx(ref, abs=1e-12)
    assert d.low < d.value < d.high
    # paired resampling: the same draws for both coefficients, so the interval of the
    # difference of an indicator with itself is exactly 0
    z = spearman_difference(x1, x1, y, n_boot=200, seed=1)
    assert z.value == 0.0 and z.low == 0.0 and z.high == 0.0


def test_statements_follow_the_statistics():
    from roverimpact.studies.indicators import compare_indicators

    rng = np.random.default_rng(0)
    n = 40
    F = np.sort(rng.uniform(100, 1000, n))
    t = pd.DataFrame({
        "F_max": F,
        "T_c_minus": F / 500.0,                              # ranks F perfectly
        "v_n": np.full(n, 0.433) + 1e-16 * rng.normal(size=n),  # constant up to round-off
        "T_n_total": rng.permutation(F),                     # unrelated to F
        "T_c_obstacle": F ** 2,                              # the same ranking as T_c^-
    })
    c = compare_indicators(t, "F_max", n_boot=300, seed=0)
    assert c.n == n
    v = c.result("v_n")
    assert v.constant and math.isnan(v.agreement.spearman.value)
    assert c.result("T_c_obstacle").spearman_gain.value == 0.0
    g = c.result("T_n_total").spearman_gain
    assert g.low > 0
    text = " ".join(c.statements)
    assert "v_n is the same for every case here" in text
    assert "T_c^- ranks F_max better than 1/2 m_total v_n^2" in text
    assert "T_c^- (obstacle row only) ranks F_max exactly as T_c^- does" in text
    assert c.statements[-1] == ("In short: T_c^- earns its keep against v_n, 1/2 m_total "
                                "v_n^2; not against T_c^- (obstacle row only) (same "
                                "ranking, or not told apart).")
    # the other way round: a baseline that ranks better than T_c^-
    t2 = t.assign(T_c_minus=rng.permutation(F), T_n_total=F)
    c2 = compare_indicators(t2, "F_max", n_boot=300, seed=0)
    assert "1/2 m_total v_n^2 ranks F_max better than T_c^-" in " ".join(c2.statements)
    # excluded cases are left out of every indicator alike
    c3 = compare_indicators(t, "F_max", exclude=np.arange(n) < 5, n_boot=0)
    assert c3.n == n - 5 and all(r.agreement.n == n - 5 for r in c3.results)


# ------------------------------------------------------------------- fixed v_n study
def test_statements_do_not_credit_a_t_c_that_does_not_rank():
    """A constant baseline cannot rank, but T_c^- earns nothing over it unless T_c^- ranks
    F_max itself: with T_c^- reversed (scipy rho = -1) or unrelated to F_max (rho near 0,
    its interval across 0), the verdict once read "T_c^- earns its keep against v_n,
    ...". Reference: scipy's spearmanr on the same table."""
    from roverimpact.studies.indicators import compare_indicators

    rng = np.random.default_rng(0)
    n = 30
    F = np.linspace(100.0, 1000.0, n)
    for T in (1.0 / F, rng.permutation(F)):
        t = pd.DataFrame({"F_max": F, "T_c_minus": T, "v_n": np.full(n, 0.3),
                          "m_total": 24.0, "m_eff_free": 10.0})
        c = compare_indicators(t, "F_max", n_boot=200, seed=0)
        rho = c.result("T_c_minus").agreement.spearman
        assert rho.value == pytest.approx(sps.spearmanr(T, F).statistic, abs=1e-12)
        assert rho.low <= 0.0
        assert c.result("v_n").constant
        text = " ".join(c.statements)
        assert "earns its keep against v_n" not in text
        assert c.statements[0].startswith("This study does not show that T_c^- ranks F_max")
        assert c.statements[-1] == ("In short: this study does not show that T_c^- ranks "
                                    "F_max, so it earns its keep against no baseline.")
    # and when it ranks (rho = 1), the constant baselines are beaten as before
    t = pd.DataFrame({"F_max": F, "T_c_minus": F / 500.0, "v_n": np.full(n, 0.3),
                      "m_total": 24.0, "m_eff_free": 10.0})
    c = compare_indicators(t, "F_max", n_boot=0)
    assert "earns its keep against v_n" in c.statements[-1]


def test_fixed_vn_study_holds_vn_and_mass_fixed():
    from roverimpact.studies import run_study
    from roverimpact.studies.config import load_study
    from roverimpact.studies.reproduce import builtin_study_path

    path = builtin_study_path("fixed_vn_configuration")
    assert path.read_text() == (EX / "study_fixed_vn.toml").read_text()
    st, _ = load_study(path)
    assert st.engines() == ("own", "mujoco")
    data = st.model_dump() | {"simulate": False}
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        t = run_study(data, Path(tmp) / "f").table
    assert len(t) == 15
    for col in ("v_n", "m_total", "T_n_total"):
        x = t[col].to_numpy(float)
        assert np.ptp(x) <= 1e-9 * x.max(), col
    assert t["v_n"].iloc[0] == pytest.approx(0.5 * math.sin(math.radians(60.0)), rel=1e-9)
    assert np.ptp(t["T_c_minus"]) > 0.5 * t["T_c_minus"].min()     # the cases differ


# ------------------------------------------------------------------- trust map
def test_trust_map_with_the_engine_as_an_axis(tmp_path, capsys):
    from roverimpact.studies.trust import TrustGrid, trust_map

    study = {"name": "three betas",
             "base": {"model": {"name": "rover2d"}, "velocity": {"u": 0.3},
                      "obstacle": {"wheel": "front", "beta_deg": 90.0},
                      "simulation": {"t_after": 0.05}},
             "grid": {"obstacle.beta_deg": [35.0, 60.0, 90.0]}}
    grid = TrustGrid(laws=("hunt-crossley",), k=(1e7,), e=(0.5,))
    res = trust_map(study, tmp_path / "t", grid=grid, engines=("own", "mujoco"))
    t = res.table
    assert t["engine"].tolist() == ["own", "mujoco"]
    r = res.results
    for row in t.itertuples():
        F = r["F_max" if row.engine == "own" else "F_max_mujoco"].to_numpy(float)
        assert row.spearman == pytest.approx(sps.spearmanr(r["T_c_minus"], F).statistic)
        assert row.spearman_v_n == pytest.approx(sps.spearmanr(r["v_n"], F).statistic)
        assert row.spearman_T_c_obstacle == pytest.approx(
            sps.spearmanr(0.5 * r["m_eff_free"] * r["v_n"] ** 2, F).statistic)
    np.testing.assert_allclose(r["F_max_mujoco"], r["F_max"], rtol=0.05)
    from roverimpact.report.trust import plot_trust_map

    files = plot_trust_map(t, tmp_path / "map")
    assert files["png"].is_file()


def test_trust_cli_two_engines_at_80_columns(tmp_path, capsys):
    assert main(["trust", "--quick", "--k", "1e7", "--e", "0.5", "-o", str(tmp_path / "t"),
                 "--engine", "own,mujoco"]) == 0
    out = capsys.readouterr().out
    assert max(map(len, fitted_lines(out))) <= 80 and "…" not in out
    assert "own simulator" in out and "MuJoCo" in out and "hunt-crossley" in out
    assert "8 simulations" in out       # 4 configurations x 1 cell x 2 engines


# ------------------------------------------------------------------- experiment
def test_experiment_baselines_against_scipy():
    from roverimpact.experiments import compare_with_model

    rng = np.random.default_rng(5)
    trials = pd.DataFrame({"beta_deg": np.repeat([20.0, 40.0, 60.0, 80.0, 90.0], 2),
                           "speed": 0.3, "F_peak": rng.uniform(100, 900, 10)})

    def model(beta, speed):
        v_n = speed * math.sin(beta)
        return {"T_c_minus": 0.5 * 10 * v_n ** 2 * (1 + 0.2 * math.cos(beta)),
                "F_max": 1000 * v_n, "v_n": v_n, "m_total": 25.0, "m_eff_free": 9.0,
                "T_n_total": 0.5 * 25.0 * v_n ** 2, "T_c_obstacle": 0.5 * 9.0 * v_n ** 2}

    c = compare_with_model(trials, model)
    mean = c.table["F_peak_mean"]
    for key, col in (("vn", "v_n"), ("Tn_total", "T_n_total"), ("Tc_obstacle", "T_c_obstacle"),
                     ("Tc", "T_c_minus")):
        assert c.stats[f"spearman_rho_{key}"] == pytest.approx(
            sps.spearmanr(mean, c.table[col]).statistic), key
    assert c.indicators is not None and c.indicators.n == 5
    assert c.indicators.result("v_n").agreement.spearman.value == pytest.approx(
        c.stats["spearman_rho_vn"])
