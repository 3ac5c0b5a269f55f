"""State blocks (issue #19, sweeps off the grid): the cases of a study that differ in the
numbers of joint values, joint rates, the speed and the impact angle of one model (a
robot file's configurations, a rover's suspension settings) are computed together on one
model (scenario.block.state_block), not built one by one (a robot file was loaded again
for every case: about 40 cases/s for the Panda).

The reference is a fresh scenario, model and setup per case (evaluate_case, through
ImpactSetup.from_scenario): the block's outputs must equal it to 1e-12, and a case that
cannot be posed must get the error it gets on its own.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from roverimpact._io import read_toml
from roverimpact.exceptions import ConfigError
from roverimpact.studies import ScenarioEvaluator, evaluate_case
from roverimpact.studies.config import apply_overrides

EX = Path(__file__).resolve().parents[1] / "examples"

COLUMNS = ("T_c_minus", "m_eff", "v_n", "F_pred", "m_total", "m_eff_free", "T_n_total",
           "T_c_obstacle")

#: examples/panda_tool_impact.toml (the Panda's TCP striking a surface) with a contact law
PANDA = {**read_toml(EX / "panda_tool_impact.toml"),
         "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8}}

ROCKER = {
    "model": {"name": "rocker_bogie", "preset": "prototype"},
    "velocity": {"u": 0.3},
    "obstacle": {"wheel": "left_front", "beta_deg": 60.0},
}


def _builds(monkeypatch) -> list:
    """Every model built from here on (scenario.build.make_model calls)."""
    from roverimpact.scenario import build

    built: list = []
    real = build.make_model
    monkeypatch.setattr(build, "make_model", lambda *a, **kw: built.append(1) or real(*a, **kw))
    return built


def _assert_one_by_one(base, overrides, got, errors=None):
    """``got`` (the evaluator's outputs) equal evaluate_case per case to 1e-12; a case
    whose evaluate_case raises has that error in ``errors`` and missing outputs."""
    for i, ov in enumerate(overrides):
        try:
            ref = evaluate_case(apply_overrides(base, ov))
        except ConfigError as exc:
            assert errors is not None and errors[i] == f"ConfigError: {exc}", i
            assert math.isnan(got["T_c_minus"][i])
            continue
        assert errors is None or errors[i] == "", (i, errors[i])
        for col in COLUMNS:
            assert got[col][i] == pytest.approx(ref[col], rel=1e-12, abs=1e-15,
                                                nan_ok=True), (i, col)


def test_a_robot_file_s_configurations_are_one_block_on_one_model(monkeypatch):
    """A random design over two joint values and a joint rate of the Panda (a URDF of
    example-robot-data, mimic fingers): one model built for all the cases (it was built
    again for each), the outputs of each case its own build's."""
    rng = np.random.default_rng(3)
    overrides = [{"configuration.joints.panda_joint2": float(a),
                  "configuration.joints.panda_joint4": float(b),
                  "velocity.joints.panda_joint1": float(c)}
                 for a, b, c in zip(rng.uniform(-1.0, 1.0, 24), rng.uniform(-2.5, -1.0, 24),
                                    rng.uniform(0.1, 1.0, 24), strict=True)]
    built = _builds(monkeypatch)
    got = ScenarioEvaluator().evaluate(PANDA, overrides)
    monkeypatch.undo()
    assert len(built) == 1
    _assert_one_by_one(PANDA, overrides, got)
    assert len(set(np.round(got["T_c_minus"], 12))) == len(overrides)  # q did change


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")
def test_suspension_settings_of_a_rover_with_a_loop_are_one_block(monkeypatch):
    """The rocker-bogie's rockers set in [configuration.joints] and given rates (its
    differential is a built-in loop), at random speeds and angles: one block of one model
    (they were a model family's blocks of one member each). The cases whose rockers open
    the loop, or whose rates pull it apart, get the error they get on their own (recorded,
    or raised without a list of errors); the others their own build's outputs. A block
    with such a case is computed case by case, on the block's model."""
    rng = np.random.default_rng(4)
    overrides = []
    for i in range(16):
        a, r = float(rng.uniform(-0.15, 0.15)), float(rng.uniform(-0.5, 0.5))
        overrides.append({
            "configuration.joints.rocker_left": a,
            "configuration.joints.rocker_right": -a if i % 5 != 3 else a + 0.1,
            "velocity.joints.rocker_left": r,
            "velocity.joints.rocker_right": -r if i % 7 != 4 else r + 0.2,
            "velocity.u": float(rng.uniform(0.1, 0.5)),
            "obstacle.beta_deg": float(rng.uniform(10.0, 90.0))})
    errors = [""] * len(overrides)
    built = _builds(monkeypatch)
    got = ScenarioEvaluator().evaluate(ROCKER, overrides, errors=errors)
    monkeypatch.undo()
    assert len(built) == 1  # the block's model, reused by its cases one by one
    assert sum(map(bool, errors)) == 5  # i = 3, 8, 13 open the loop; 4, 11 pull it apart
    assert "open the loop 'differential'" in errors[3]
    assert "joint rates open the loop 'differential'" in errors[4]
    _assert_one_by_one(ROCKER, overrides, got, errors)
    with pytest.raises(ConfigError, match="open the loop 'differential'"):
        ScenarioEvaluator().evaluate(ROCKER, overrides)


def test_a_file_rover_s_speeds_and_angles_are_one_block(monkeypatch):
    """A floating MJCF rover standing on its wheels (ground rows) at random speeds and
    angles, every case a group of its own: one block, one model (each case was built
    on its own)."""
    base = {"model": {"file": str(EX / "mjcf_rover.xml"),
                      "wheels": {"front": {"frame": "front_tire"},
                                 "rear": {"frame": "rear_tire"}}},
            "velocity": {"u": 0.5},
            "obstacle": {"wheel": "front", "beta_deg": 45.0},
            "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8}}
    rng = np.random.default_rng(5)
    overrides = [{"velocity.u": float(u), "obstacle.beta_deg": float(b)}
                 for u, b in zip(rng.uniform(0.1, 1.0, 12), rng.uniform(5.0, 90.0, 12),
                                 strict=True)]
    built = _builds(monkeypatch)
    got = ScenarioEvaluator().evaluate(base, overrides)
    monkeypatch.undo()
    assert len(built) == 1
    _assert_one_by_one(base, overrides, got)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")
def test_mimic_joints_of_a_plain_urdf_in_a_block(tmp_path):
    """The rocker-bogie written as a plain URDF, its differential a mimic joint: setting
    one rocker turns the other (each case as its own build), and cases that set both
    rockers to values the mimic does not keep are refused as on their own (the check of
    kept values runs over the block's values as arrays)."""
    from roverimpact.models import export_plain_urdf, rocker_bogie

    base = {**export_plain_urdf(rocker_bogie(), tmp_path / "rb.urdf"),
            "velocity": {"u": 0.2}, "obstacle": {"wheel": "left_front", "beta_deg": 30.0}}
    one = [{"configuration.joints.rocker_left": a} for a in np.linspace(-0.2, 0.2, 7)]
    _assert_one_by_one(base, one, ScenarioEvaluator().evaluate(base, one))
    both = [{"configuration.joints.rocker_left": a,
             "configuration.joints.rocker_right": -a if i != 2 else 0.3}
            for i, a in enumerate(np.linspace(-0.2, 0.2, 5))]
    errors = [""] * len(both)
    got = ScenarioEvaluator().evaluate(base, both, errors=errors)
    assert [bool(e) for e in errors] == [False, False, True, False, False]
    assert "was changed to" in errors[2]
    _assert_one_by_one(base, both, got, errors)


def test_joint_sweeps_are_cheap_cases():
    """A study of joint values, rates, speeds and angles of one model gets the chunks of
    cheap cases (CHEAP_AUTO_CHUNK); a model on a terrain does not."""
    from roverimpact.studies.sweep import CHEAP_AUTO_CHUNK, MIN_AUTO_CHUNK, prepare_study

    grid = {"configuration.joints.panda_joint2": {"start": -1.0, "stop": 1.0, "num": 60},
            "velocity.joints.panda_joint1": {"start": 0.1, "stop": 1.0, "num": 50}}
    assert prepare_study({"name": "p", "base": PANDA, "grid": grid}).chunk_size == \
        CHEAP_AUTO_CHUNK
    terrain = {**ROCKER, "terrain": {"plane": {"normal": [-0.17, 0.0, 0.98]}}}
    grid = {"configuration.joints.rocker_left": [0.0] * 3000}
    assert prepare_study({"name": "t", "base": terrain, "grid": grid}).chunk_size == \
        MIN_AUTO_CHUNK


def test_the_model_is_shared_across_configurations_unless_declared_loops_need_them():
    """Scenarios that differ in [configuration] only have one model (model_key), unless
    they declare loops ([[contacts.loops]]: a distance loop without a length keeps the
    distance it has in the configuration)."""
    from roverimpact.scenario import load_scenario, scenario_from_dict
    from roverimpact.scenario.build import model_key

    def keys(sc, joints):
        raw = sc.model_dump(mode="json", exclude_none=True)
        return {model_key(scenario_from_dict(
            apply_overrides(raw, {f"configuration.joints.{k}": v for k, v in j.items()})))
            for j in joints}

    panda = scenario_from_dict(PANDA)
    assert len(keys(panda, [{"panda_joint2": 0.1}, {"panda_joint2": 0.3}])) == 1
    sawppy = load_scenario(EX / "sawppy_like_beta.toml")
    assert sawppy.contacts.loops
    assert len(keys(sawppy, [{"rocker_left": 0.0}, {"rocker_left": 0.05}])) == 2


def test_the_example_joint_map_runs_as_one_block_per_chunk(tmp_path, monkeypatch):
    """examples/study_panda_joints.toml (docs/studies.md): 2 000 configurations of the
    Panda, one model per chunk (a chunk of cheap cases: one chunk here) and one for the
    study's checks (they built one each: five); its T_c^- at both ends of the grid are
    their scenarios' own."""
    from roverimpact.studies import run_study
    from roverimpact.studies.config import load_study

    study, _ = load_study(EX / "study_panda_joints.toml")
    built = _builds(monkeypatch)
    res = run_study(study, tmp_path / "out")
    monkeypatch.undo()
    table = res.table
    # one for the study's checks (the base and the ends of both joints' ranges share it)
    # and one for the sweep's one chunk: not one per case, nor one per check
    assert len(table) == 2000 and len(built) == 2
    for i in (0, len(table) - 1):
        ov = {k: float(table[k].iloc[i]) for k in study.grid}
        ref = evaluate_case(apply_overrides(study.base, ov))
        assert table["T_c_minus"].iloc[i] == pytest.approx(ref["T_c_minus"], rel=1e-12)


def test_the_checks_of_k_states_are_those_of_the_first_that_fails():
    """check_loop_closed, the loop-rate check and the zero-contact-row check take k states
    at once (a state block's screen): they raise what the first failing state raises on
    its own, and nothing where every state passes."""
    from roverimpact.models import rocker_bogie
    from roverimpact.models.joints import set_joint_rate, set_joint_value
    from roverimpact.scenario.build import (
        _check_contact_rows,
        _check_loop_rates,
        check_loop_closed,
    )

    mbm = rocker_bogie()
    q0 = np.array(mbm.params["q_nominal"], dtype=float)
    Q = np.array([set_joint_value(mbm, q0, "rocker_left", a) for a in (0.0, 0.1, 0.0, 0.2)])
    Q[[0, 2]] = [set_joint_value(mbm, q, "rocker_right", 0.0) for q in Q[[0, 2]]]
    Q[1] = set_joint_value(mbm, Q[1], "rocker_right", -0.1)  # closed; 3 is open
    phi, J = mbm.loop_closure(Q)
    with pytest.raises(ConfigError) as batch:
        check_loop_closed(mbm, phi, J)
    with pytest.raises(ConfigError) as own:
        check_loop_closed(mbm, *mbm.loop_closure(Q[3]))
    assert str(batch.value) == str(own.value)
    check_loop_closed(mbm, phi[:3], J)  # the first three are closed
    V = np.zeros((3, mbm.model.nv))
    V[2] = set_joint_rate(mbm, V[2], "rocker_left", 0.5)  # pulls the loop apart
    with pytest.raises(ConfigError) as batch:
        _check_loop_rates(mbm, J, V)
    with pytest.raises(ConfigError) as own:
        _check_loop_rates(mbm, J, V[2])
    assert str(batch.value) == str(own.value)
    _check_loop_rates(mbm, J, V[:2])
    labels = ["ground:a:normal", "obstacle:b:normal", "loop:c"]
    A = np.ones((3, 3, 4))
    A[1, 1] = 0.0
    A[2, 2] = 0.0  # not a contact row: never refused
    with pytest.raises(ConfigError, match=r"\['obstacle:b:normal'\] are zero"):
        _check_contact_rows(A, labels)
    _check_contact_rows(A[[0, 2]], labels)
