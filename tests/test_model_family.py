"""Model families (issue #19: model-changing sweeps): one Pinocchio model rewritten member
by member, and the impact setups of a block of scenarios computed together, against a
freshly built model / setup per member."""

from __future__ import annotations

import numpy as np
import pytest

import roverimpact as ri
from roverimpact.exceptions import ModelError
from roverimpact.models import rocker_bogie
from roverimpact.models.family import ModelFamily, family_numbers, has_family
from roverimpact.models.kinematics import ConstraintSet
from roverimpact.scenario import ImpactSetup, scenario_from_dict
from roverimpact.scenario.block import block_key, impact_block
from roverimpact.scenario.build import (
    candidate_constraints,
    configuration,
    normal_from_beta,
    velocity,
)
from roverimpact.studies import ScenarioEvaluator, evaluate_case
from roverimpact.studies.config import apply_overrides

ROVER = {
    "model": {"name": "rocker_bogie", "preset": "prototype"},
    "velocity": {"u": 0.3},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "left_front", "beta_deg": 60.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 1.0},
}


def _random_params(rng, k):
    """Parameter sets that change masses, the COM, lengths, pivots and the wheel radius."""
    out = []
    for _ in range(k):
        out.append({
            "chassis_mass": float(rng.uniform(8.0, 25.0)),
            "chassis_com_above_pivot": float(rng.uniform(-0.05, 0.25)),
            "com_x": float(rng.uniform(-0.05, 0.05)),
            "rocker_mass": float(rng.uniform(0.5, 2.0)),
            "wheel_mass": float(rng.uniform(0.3, 1.0)),
            "wheel_radius": float(rng.uniform(0.07, 0.15)),
            "front_x": float(rng.uniform(0.25, 0.4)),
            "rear_x": float(rng.uniform(-0.4, -0.25)),
            "track": float(rng.uniform(0.4, 0.6)),
            "bogie_pivot_height": float(rng.uniform(0.05, 0.12)),
        })
    out[1] = {"chassis_mass": 17.0}  # a member that sets one parameter only
    out[2] = {}
    return out


def _close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max()))


@pytest.mark.parametrize("preset", ["prototype", "mer"])
def test_rewritten_model_gives_the_fresh_models_M_A_v(preset):
    """M, A (every candidate row, the obstacle normal turning from member to member) and
    v of each member, from one Pinocchio model rewritten member by member, equal those of
    a model built for the member; so do its nominal q and total mass."""
    rng = np.random.default_rng(11)
    params = _random_params(rng, 9)
    _assert_members_are_fresh_builds(lambda **p: rocker_bogie(preset, **p),
                                     family_numbers("rocker_bogie", preset, params), params,
                                     scenario_from_dict(ROVER), rng)


def _assert_members_are_fresh_builds(build, nums, params, sc, rng):
    """Each member of the family ``nums`` (of parameter sets ``params``), from one model
    rewritten member by member, has the M, A (every candidate row), v, nominal q and total
    mass of ``build(**params[i])``."""
    fam = ModelFamily(build(**params[0]), nums)
    mbm = fam.mbm
    Q = configuration(mbm, sc.configuration, q_nominal=nums.q_nominal)
    u = rng.uniform(0.1, 0.5, len(params))
    V = velocity(mbm, Q[0], sc.velocity, u=u, wheel_radius=nums.wheel_radius)
    beta = np.deg2rad(rng.uniform(5.0, 90.0, len(params)))
    normals = normal_from_beta(beta, (1.0, 0.0, 0.0))
    cons = candidate_constraints(mbm, sc.obstacle, sc.contacts, normals[0])
    M, A = ConstraintSet(mbm, cons).evaluate_members(fam, Q,
                                                     normals={len(cons) - 1: normals})
    for i, p in enumerate(params):
        fresh = build(**p)
        q = configuration(fresh, sc.configuration)
        np.testing.assert_array_equal(Q[i], q)
        assert nums.total_mass()[i] == sum(Y.mass for Y in fresh.model.inertias)
        _close(V[i], velocity(fresh, q, sc.velocity.model_copy(update={"u": u[i]})))
        Mi, Ai = ConstraintSet(fresh, candidate_constraints(
            fresh, sc.obstacle, sc.contacts, normals[i])).evaluate(q)
        _close(M[i], Mi)
        _close(A[i], Ai)
    assert len({round(float(m), 9) for m in M[:, 0, 0]}) > 5  # the model did change


def test_family_writes_only_what_changes():
    """A family that changes the chassis mass rewrites one inertia and no placement."""
    nums = family_numbers("rocker_bogie", None, [{"chassis_mass": m} for m in (10, 12, 14)])
    fam = ModelFamily(rocker_bogie(chassis_mass=10), nums)
    assert fam._inertias == [0] and fam._placements == []
    fam.write(2)
    assert fam.mbm.model.inertias[1].mass == 14.0
    with pytest.raises(ValueError):  # numbers of another structure (3 bodies)
        ModelFamily(rocker_bogie(), _other_numbers())


def test_family_writes_what_differs_from_its_model_even_if_the_same_in_every_member():
    """A family whose members all keep one number at another value than the model it
    rewrites had (a study's second block of 256 cases, whose model is the family's first
    case): that body was left as built, and every member's T_c^- came out 40 % low with
    no error. It is written now: the evaluator's cases equal evaluate_case's."""
    nums = family_numbers("rocker_bogie", None, [{"chassis_mass": 25.0}] * 3)
    fam = ModelFamily(rocker_bogie(chassis_mass=10.0), nums)
    assert fam._inertias == [0]
    fam.write(1)
    assert fam.mbm.model.inertias[1].mass == 25.0
    base = {**ROVER, "velocity": {"u": 0.3}}
    overrides = [{"model.params.chassis_mass": 10.0 + 0.01 * i,
                  "model.params.wheel_radius": 0.1} for i in range(256)]
    overrides += [{"model.params.chassis_mass": 25.0,
                   "model.params.wheel_radius": 0.1 + 1e-4 * i} for i in range(4)]
    got = ScenarioEvaluator().evaluate(base, overrides)
    for i in (0, 255, 256, 259):
        ref = evaluate_case(apply_overrides(base, overrides[i]))
        assert got["T_c_minus"][i] == pytest.approx(ref["T_c_minus"], rel=1e-12), i


def _other_numbers():
    from roverimpact.models._build import FamilyNumbers

    n = family_numbers("rocker_bogie", None, [{}])
    return FamilyNumbers(n.mass[:, :3], n.lever[:, :3], n.inertia[:, :3],
                         n.translation[:, :3], n.q_nominal, n.wheel_radius)


@pytest.mark.parametrize("bad", [{"rear_x": 0.5}, {"chassis_mass": -1.0},
                                 {"bogie_pivot_height": 0.3}, {"wheel_radius": float("nan")},
                                 {"no_such": 1.0}, {"track": "wide"}])
def test_family_numbers_refuse_what_the_builder_refuses(bad):
    _assert_refused_as_by_the_builder(lambda **p: rocker_bogie("prototype", **p),
                                      "rocker_bogie", "prototype", bad, {"chassis_mass": 12.0})


def _assert_refused_as_by_the_builder(build, name, preset, bad, good):
    """family_numbers of ``[good, bad]`` raises the builder's own error for ``bad``."""
    with pytest.raises(ModelError) as ref:
        build(**bad)
    with pytest.raises(ModelError) as got:
        family_numbers(name, preset, [good, bad])
    assert str(got.value) == str(ref.value)


def test_block_key():
    """Numbers of model.params, the speed and the angle may differ within a block; which
    parameters are set, strings, and every other table may not. No block for models
    without family numbers, terrain or declared loops."""
    def key(**ov):
        return block_key(scenario_from_dict(apply_overrides(ROVER, ov)))

    k = key(**{"model.params.chassis_mass": 12.0})
    assert k is not None and all(has_family(n) for n in ("rocker_bogie", "rover2d",
                                                          "rigid_body"))
    assert not has_family(None)  # a robot file's model
    assert key(**{"model.params.chassis_mass": 15, "velocity.u": 0.1,
                  "obstacle.beta_deg": 20.0}) == k
    for ov in ({"model.params.com_x": 0.0}, {"obstacle.wheel": "right_front"},
               {"contacts.ground": "noslip"}, {"model.preset": "mer"},
               {"model.params.chassis_mass": "12"}, {"constraints": "all"},
               {"configuration.base.yaw_deg": 10.0}):
        assert key(**{"model.params.chassis_mass": 12.0, **ov}) != k, ov
    rover2d = key(**{"model": {"name": "rover2d"}, "obstacle.wheel": "front"})
    assert rover2d is not None and rover2d != k
    assert key(**{"model": {"name": "rover2d", "params": {"suspension": "rocker"}},
                  "obstacle.wheel": "front"}) != rover2d
    rigid = key(**{"model": {"name": "rigid_body"}, "obstacle": {"frame": "contact",
                                                                 "beta_deg": 30.0}})
    assert rigid is not None and rigid not in (k, rover2d)
    from pathlib import Path

    from roverimpact.scenario import load_scenario

    mjcf = Path(__file__).resolve().parents[1] / "examples" / "mjcf_rover_beta.toml"
    assert block_key(load_scenario(mjcf)) is None


SETUPS = [
    {},
    {"contacts": {"ground": "noslip"}},
    {"contacts": {"ground": "coulomb", "mu": 0.4}},
    {"constraints": "all"},
    {"constraints": ["ground:*:normal"], "obstacle": {"wheel": "right_middle",
                                                      "beta_deg": 45.0}},
    {"obstacle": {"wheel": "left_rear", "normal": [-0.6, 0.1, 0.8]}},
    {"configuration": {"base": {"yaw_deg": 30.0, "roll_deg": 3.0, "z": 0.5},
                       "joints": {"bogie_left": 0.05}},
     "velocity": {"u": 0.3, "joints": {"bogie_left": 0.2}}},
    {"contacts": {"ground": "normal", "locked": ["bogie_right"]}},
]


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # bogie set
@pytest.mark.parametrize("extra", SETUPS)
def test_impact_block_is_the_setup_of_each_scenario(extra):
    """M, v, the active set and the active rows of each member of a block equal those of
    ImpactSetup.from_scenario (fresh model) for its scenario, to 1e-12."""
    rng = np.random.default_rng(3)
    scs = _scenarios({**ROVER, **extra}, _random_params(rng, 7), rng)
    keys = {block_key(sc) for sc in scs}
    params_set = {tuple(sorted(sc.model.params)) for sc in scs}
    if len(keys) != 1:  # members that set other parameters: give them all the same
        assert len(params_set) > 1
        scs = [sc for sc in scs if tuple(sorted(sc.model.params)) == max(params_set)]
    _assert_block_is_each_setup(scs)


def _scenarios(base, params, rng):
    """A scenario of ``base`` per parameter set, each at its own speed and (unless the
    obstacle has a normal) angle, the first at 90 degrees."""
    scs = []
    for i, p in enumerate(params):
        ov = {f"model.params.{k}": v for k, v in p.items()}
        ov["velocity.u"] = float(rng.uniform(0.1, 0.5))
        if "normal" not in base["obstacle"]:
            ov["obstacle.beta_deg"] = float(rng.uniform(5.0, 90.0)) if i else 90.0
        scs.append(scenario_from_dict(apply_overrides(base, ov)))
    return scs


def _assert_block_is_each_setup(scs):
    """impact_block of ``scs`` equals ImpactSetup.from_scenario of each, to 1e-12."""
    blk = impact_block(scs)
    for i, sc in enumerate(scs):
        ref = ImpactSetup.from_scenario(sc)
        _close(blk.M[i], ref.M)
        _close(blk.v[i], ref.v)
        _close(blk.q[i], ref.q)
        assert blk.labels == ref.candidate_labels
        rows = np.flatnonzero(blk.active[i])
        assert tuple(blk.labels[r] for r in rows) == ref.labels
        _close(blk.A[i][rows], ref.A)
        assert blk.total_mass[i] == sum(Y.mass for Y in ref.model.model.inertias)


def test_impact_block_refuses_scenarios_of_two_blocks():
    a = scenario_from_dict(apply_overrides(ROVER, {"model.params.chassis_mass": 12.0}))
    b = scenario_from_dict(apply_overrides(ROVER, {"obstacle.wheel": "right_front"}))
    from roverimpact.exceptions import InputError

    with pytest.raises(InputError):
        impact_block([a, b])
    with pytest.raises(InputError):  # a scenario with declared loops has no block
        impact_block([scenario_from_dict(apply_overrides(ROVER, {"contacts.loops": [
            {"kind": "distance", "a": "left_rocker", "b": "right_rocker"}]}))])


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.PullingContactWarning")  # noslip
def test_evaluator_blocks_match_evaluate_case():
    """Cases of their own in two blocks (two obstacle wheels), wheel radius and lengths
    changed, no-slip ground: the evaluator's outputs equal evaluate_case per case."""
    rng = np.random.default_rng(8)
    base = {**ROVER, "contacts": {"ground": "noslip"}}
    overrides = []
    for i in range(16):
        overrides.append({
            "obstacle.wheel": "left_front" if i % 3 else "right_middle",
            "obstacle.beta_deg": float(rng.uniform(10.0, 90.0)),
            "velocity.u": float(rng.uniform(0.1, 0.5)),
            "model.params.wheel_radius": float(rng.uniform(0.08, 0.14)),
            "model.params.front_x": float(rng.uniform(0.25, 0.4)),
            "model.params.chassis_com_above_pivot": float(rng.uniform(0.0, 0.2))})
    _assert_evaluator_is_evaluate_case(base, overrides)


def _assert_evaluator_is_evaluate_case(base, overrides):
    got = ScenarioEvaluator().evaluate(base, overrides)
    for i, ov in enumerate(overrides):
        ref = evaluate_case(apply_overrides(base, ov))
        for col in ("T_c_minus", "m_eff", "v_n", "F_pred", "m_total", "m_eff_free",
                    "T_n_total", "T_c_obstacle"):
            assert got[col][i] == pytest.approx(ref[col], rel=1e-12, abs=1e-15), (i, col)


def test_evaluator_bad_case_raises_as_evaluate_case():
    """A bad parameter set in a block: the error of that case's own build."""
    overrides = [{"model.params.chassis_mass": 12.0, "obstacle.beta_deg": 30.0},
                 {"model.params.chassis_mass": -3.0, "obstacle.beta_deg": 40.0}]
    with pytest.raises(ModelError) as ref:
        evaluate_case(apply_overrides(ROVER, overrides[1]))
    with pytest.raises(ModelError) as got:
        ScenarioEvaluator().evaluate(ROVER, overrides)
    assert str(got.value) == str(ref.value)


def test_study_cases_of_their_own_warn_of_a_pulling_wheel():
    """A study whose every case is of its own (another speed: cases batched by shape;
    another chassis mass: a model family's block) with ``contacts.ground = "noslip"``
    warns of the held wheel that needs a pulling impulse, as ``energy_of`` of the same
    scenario does (right front wheel of the rocker-bogie at 60 deg); the study path was
    silent. The default ground holds no pulling wheel and stays silent."""
    import warnings

    from roverimpact.exceptions import HeldRowsWarning, PullingContactWarning
    from roverimpact.studies.evaluate import ScenarioEvaluator

    base = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.5},
            "obstacle": {"wheel": "left_front", "beta_deg": 60.0},
            "contacts": {"ground": "noslip"}}
    with pytest.warns(PullingContactWarning, match=r"ground:right_front .*-0\.616 N s"):
        ri.energy_of(base)
    speeds = [{"velocity.u": 0.4}, {"velocity.u": 0.5}]
    masses = [{"model.params.chassis_mass": m} for m in (10.0, 12.0)]
    for overrides in (speeds, masses):
        with pytest.warns(PullingContactWarning, match=r"ground:right_front .*N s"):
            out = ScenarioEvaluator().evaluate(base, overrides)
        assert np.isfinite(out["T_c_minus"]).all()
    default = {k: v for k, v in base.items() if k != "contacts"}
    with warnings.catch_warnings():
        warnings.simplefilter("error", HeldRowsWarning)
        for overrides in (speeds, masses):
            ScenarioEvaluator().evaluate(default, overrides)


# -- the 2-D rover (DETC2014-35554's): its three suspensions, with and without a middle wheel

ROVER2D = {
    "model": {"name": "rover2d"},
    "velocity": {"u": 0.4},
    "contacts": {"ground": "normal"},
    "obstacle": {"wheel": "front", "beta_deg": 60.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 1.0},
}
STRUCTURES_2D = [{"suspension": s, "middle_wheel": m}
                 for s in ("rigid", "rocker", "prismatic") for m in (False, True)]


def _random_params_2d(rng, k, structure):
    """Parameter sets of one structure that change masses, h, the COM offset, lengths,
    the wheel radius, the rocker pivot and the strut mass."""
    out = []
    for _ in range(k):
        out.append({**structure,
                    "chassis_mass": float(rng.uniform(12.0, 30.0)),
                    "wheel_mass": float(rng.uniform(1.0, 4.0)),
                    "wheel_radius": float(rng.uniform(0.1, 0.2)),
                    "wheelbase": float(rng.uniform(0.5, 0.8)),
                    "h": float(rng.uniform(0.3, 0.55)),
                    "com_x": float(rng.uniform(-0.08, 0.08)),
                    "rocker_mass": float(rng.uniform(0.5, 2.5)),
                    "rocker_pivot_height": float(rng.uniform(0.05, 0.15)),
                    "strut_mass": float(rng.uniform(0.2, 1.0))})
    out[1] = {**structure, "h": 0.42}  # a member that sets one number only
    out[2] = dict(structure)
    return out


@pytest.mark.parametrize("structure", STRUCTURES_2D)
def test_rover2d_rewritten_model_gives_the_fresh_models_M_A_v(structure):
    """As for the rocker-bogie: each member of a rover2d family, from one rewritten model,
    has the M, A (every candidate row), v, nominal q and total mass of a model built for
    it by ``rover2d``."""
    from roverimpact.models import rover2d

    rng = np.random.default_rng(12)
    params = _random_params_2d(rng, 8, structure)
    _assert_members_are_fresh_builds(rover2d, family_numbers("rover2d", None, params), params,
                                     scenario_from_dict(ROVER2D), rng)


@pytest.mark.parametrize("bad", [{"h": 0.1, "wheel_mass": 40.0}, {"chassis_mass": -1.0},
                                 {"wheel_radius": float("nan")}, {"no_such": 1.0},
                                 {"wheelbase": "long"}, {"com_x": float("inf")}])
def test_rover2d_family_numbers_refuse_what_the_builder_refuses(bad):
    from roverimpact.models import rover2d

    _assert_refused_as_by_the_builder(rover2d, "rover2d", None, bad, {"chassis_mass": 12.0})


def test_rover2d_family_numbers_are_of_one_structure():
    """Two suspensions are two families; a middle_wheel of 1 and 0 (numbers to a block's
    key) is refused as the builder refuses it, not taken for two structures."""
    from roverimpact.models import rover2d

    with pytest.raises(ValueError, match="more than one structure"):
        family_numbers("rover2d", None, [{"suspension": "rigid"}, {"suspension": "rocker"}])
    with pytest.raises(ModelError, match="no presets"):
        family_numbers("rover2d", "mer", [{}])
    with pytest.raises(ModelError) as ref:
        rover2d(middle_wheel=1)
    with pytest.raises(ModelError) as got:
        family_numbers("rover2d", None, [{"middle_wheel": 1}, {"middle_wheel": 0}])
    assert str(got.value) == str(ref.value) and "true or false" in str(ref.value)


SETUPS_2D = [
    {},
    {"contacts": {"ground": "noslip"}},
    {"contacts": {"ground": "coulomb", "mu": 0.5}},
    {"constraints": "all"},
    {"obstacle": {"wheel": "rear", "beta_deg": 30.0}},
    {"obstacle": {"wheel": "front", "normal": [-0.8, 0.0, 0.6]}},
    {"configuration": {"base": {"z": 0.05}}},
]


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # base z set
@pytest.mark.parametrize("structure", [*STRUCTURES_2D[::2], STRUCTURES_2D[3]])
@pytest.mark.parametrize("extra", SETUPS_2D)
def test_rover2d_impact_block_is_the_setup_of_each_scenario(structure, extra):
    """M, v, q, the active set and the active rows of each member of a rover2d block equal
    those of ImpactSetup.from_scenario for its scenario, to 1e-12."""
    rng = np.random.default_rng(4)
    scs = _scenarios({**ROVER2D, **extra}, _random_params_2d(rng, 6, structure), rng)
    most = max(len(sc.model.params) for sc in scs)
    scs = [sc for sc in scs if len(sc.model.params) == most]  # one block: the same keys
    assert len({block_key(sc) for sc in scs}) == 1 and len(scs) >= 4
    _assert_block_is_each_setup(scs)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # rocker set
@pytest.mark.parametrize("extra", [
    {"configuration": {"joints": {"rocker": 0.05}},
     "velocity": {"u": 0.3, "joints": {"rocker": 0.2}}},
    {"contacts": {"ground": "normal", "locked": ["rocker"]}},
    {"contacts": {"ground": "noslip"}, "obstacle": {"wheel": "middle", "beta_deg": 45.0}},
])
def test_rover2d_rocker_block_with_its_joint_set_or_locked(extra):
    """The rocker's own joint in a block: set in the configuration and the velocity, or
    locked; and the middle wheel hitting the obstacle. As for the other setups."""
    rng = np.random.default_rng(6)
    structure = {"suspension": "rocker", "middle_wheel": True}
    scs = _scenarios({**ROVER2D, **extra}, _random_params_2d(rng, 6, structure)[3:] * 2, rng)
    _assert_block_is_each_setup(scs)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.PullingContactWarning")  # noslip
@pytest.mark.parametrize("suspension", ["rigid", "rocker"])
def test_rover2d_evaluator_blocks_match_evaluate_case(suspension):
    """A random design of the 2-D rover's h, wheel mass, speed and angle (every case
    another model, as a study of the papers' COM height): the evaluator's outputs equal
    evaluate_case per case."""
    rng = np.random.default_rng(9)
    base = {**ROVER2D, "model": {"name": "rover2d", "params": {"suspension": suspension}}}
    overrides = []
    for _ in range(12):
        overrides.append({
            "obstacle.beta_deg": float(rng.uniform(10.0, 90.0)),
            "velocity.u": float(rng.uniform(0.1, 0.5)),
            "model.params.h": float(rng.uniform(0.25, 0.5)),
            "model.params.wheel_mass": float(rng.uniform(1.0, 5.0))})
    _assert_evaluator_is_evaluate_case(base, overrides)


def test_each_family_of_one_call_has_its_own_pulling_check():
    """Two model families in one evaluate call, the first on a normal ground and the
    second on a no-slip ground: the second still warns of its pulling wheel (a draft of
    this stop decided the check once per call, from the first family)."""
    from roverimpact.exceptions import PullingContactWarning

    base = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.5},
            "obstacle": {"wheel": "left_front", "beta_deg": 60.0}}
    overrides = [{"contacts.ground": ground, "model.params.chassis_mass": m}
                 for ground in ("normal", "noslip") for m in (10.0, 12.0)]
    with pytest.warns(PullingContactWarning, match=r"ground:right_front"):
        out = ScenarioEvaluator().evaluate(base, overrides)
    assert np.isfinite(out["T_c_minus"]).all()


RIGID = {
    "model": {"name": "rigid_body"},
    "velocity": {"u": 0.5},
    "obstacle": {"frame": "contact", "beta_deg": 90.0},
    "contact_law": {"name": "hunt-crossley", "k": 1.0e7, "e": 0.8},
}


def _random_params_rigid(rng, k):
    out = [{"mass": float(rng.uniform(2.0, 50.0)), "inertia": float(rng.uniform(0.1, 3.0)),
            "com_height": float(rng.uniform(-0.2, 0.6)), "lever": float(rng.uniform(-0.5, 0.5))}
           for _ in range(k)]
    out[1] = {"com_height": 0.25}  # a member that sets one number only
    out[2] = {}
    return out


def test_rigid_body_rewritten_model_gives_the_fresh_models_M_A_v():
    """The rigid body's family: its mass, inertia and contact corner (a frame whose
    placement is a parameter) written member by member into one model give the M, A, v,
    nominal q and total mass of a model built for each member."""
    from roverimpact.models import rigid_body

    assert has_family("rigid_body")
    rng = np.random.default_rng(21)
    params = _random_params_rigid(rng, 9)
    _assert_members_are_fresh_builds(rigid_body, family_numbers("rigid_body", None, params),
                                     params, scenario_from_dict(RIGID), rng)


@pytest.mark.parametrize("bad", [{"mass": -1.0}, {"inertia": float("nan")},
                                 {"lever": float("inf")}, {"no_such": 1.0},
                                 {"com_height": "low"}, {"mass": True}])
def test_rigid_body_family_numbers_refuse_what_the_builder_refuses(bad):
    from roverimpact.models import rigid_body

    _assert_refused_as_by_the_builder(rigid_body, "rigid_body", None, bad, {"mass": 12.0})
    with pytest.raises(ModelError, match="no presets"):
        family_numbers("rigid_body", "heavy", [{}])


def test_rigid_body_family_takes_the_numbers_the_builder_takes():
    """numpy numbers, which the family's fast path does not read, are read from the
    checked parameter sets."""
    from roverimpact.models import rigid_body

    params = [{"mass": np.int64(3), "lever": np.float32(0.25)}, {"com_height": 0.5},
              *({"mass": float(m), "inertia": np.int64(2)} for m in range(4, 9))]
    rng = np.random.default_rng(2)
    _assert_members_are_fresh_builds(rigid_body, family_numbers("rigid_body", None, params),
                                     params, scenario_from_dict(RIGID), rng)


def test_rigid_body_design_matches_the_closed_form_and_evaluate_case():
    """A random design of every rigid-body parameter, the speed and the angle (every case
    another model, one block): T_c^- and m_eff are the textbook closed form of the body
    hitting at its corner (roverimpact.models.rigid_body's docstring),
    1/m_eff = 1/m + (h sin(beta) - l cos(beta))^2 / I, T_c^- = m_eff (u sin(beta))^2 / 2,
    and equal one evaluate_case per case."""
    rng = np.random.default_rng(5)
    overrides = []
    for _ in range(40):
        p = _random_params_rigid(rng, 3)[0]
        overrides.append({**{f"model.params.{k}": v for k, v in p.items()},
                          "obstacle.beta_deg": float(rng.uniform(5.0, 90.0)),
                          "velocity.u": float(rng.uniform(0.1, 1.0))})
    got = ScenarioEvaluator().evaluate(RIGID, overrides)
    for i, ov in enumerate(overrides):
        m, inertia = ov["model.params.mass"], ov["model.params.inertia"]
        h, lever = ov["model.params.com_height"], ov["model.params.lever"]
        beta, u = np.deg2rad(ov["obstacle.beta_deg"]), ov["velocity.u"]
        m_eff = 1.0 / (1.0 / m + (h * np.sin(beta) - lever * np.cos(beta)) ** 2 / inertia)
        assert got["m_eff"][i] == pytest.approx(m_eff, rel=1e-12)
        assert got["T_c_minus"][i] == pytest.approx(0.5 * m_eff * (u * np.sin(beta)) ** 2,
                                                    rel=1e-12)
        assert got["m_total"][i] == m
    _assert_evaluator_is_evaluate_case(RIGID, overrides[:12])
