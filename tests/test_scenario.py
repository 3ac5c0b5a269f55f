"""Scenarios -> (M, A, v) -> T_c^-: limit cases against closed forms and independent methods."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.exceptions import ConfigError, InputError, ModelError
from roverimpact.models import export_urdf, rocker_bogie, rover2d
from roverimpact.scenario import Scenario, energy_of, load_scenario, sweep_energy
from tests.reference.rovers import FREE_ROOT_ARM_MJCF

ROVER2D = {"model": {"name": "rover2d"}, "velocity": {"u": 0.5}, "constraints": "all",
           "obstacle": {"wheel": "front", "beta_deg": 45.0}}
RB = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.2}, "constraints": "all",
      "obstacle": {"wheel": "left_front", "beta_deg": 30.0}}


def raw(base, **upd):
    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
    for k, v in upd.items():
        d[k] = {**d.get(k, {}), **v} if isinstance(v, dict) else v
    return d


def sc(base, **upd):
    return Scenario.model_validate(raw(base, **upd))


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # "all" held
@pytest.mark.parametrize("base", [ROVER2D, RB])
def test_beta_zero_gives_no_effective_energy(base):
    """beta = 0: n = z is orthogonal to the rim-point velocity of a rolling wheel -> T_c^- = 0.

    For a wheel rolling at u, the point c - r n has velocity u(1 - cos b, 0, -sin b), so
    -n.v_p = u sin(beta) (derived by hand); every ground row is satisfied by rolling.
    """
    e = energy_of(sc(base, obstacle={"beta_deg": 0.0}))
    assert e.T > 0 and abs(e.T_c_minus) < 1e-12 * e.T and abs(e.v_n) < 1e-12
    for beta in (20.0, 60.0, 90.0):
        e = energy_of(sc(base, obstacle={"beta_deg": beta}))
        u = base["velocity"]["u"]
        assert e.v_n == pytest.approx(u * np.sin(np.deg2rad(beta)), rel=1e-12)


@pytest.mark.parametrize("base", [ROVER2D, RB])
def test_tc_equals_half_meff_vn2_when_other_rows_are_admissible(base):
    """If A_other v = 0, T_c^- = 1/2 m_eff v_n^2 (Schur-complement identity), m_eff >= m_free."""
    e = energy_of(sc(base))
    assert e.T_c_minus == pytest.approx(0.5 * e.m_eff * e.v_n**2, rel=1e-9)
    assert e.m_eff >= e.m_eff_free * (1 - 1e-12)


def _free_body_urdf(tmp_path, m=3.0, com=(0.1, -0.05, 0.2), I=(0.2, 0.3, 0.15)):
    txt = f"""<robot name="brick"><link name="brick"><inertial>
      <origin xyz="{com[0]} {com[1]} {com[2]}" rpy="0 0 0"/><mass value="{m}"/>
      <inertia ixx="{I[0]}" ixy="0" ixz="0" iyy="{I[1]}" iyz="0" izz="{I[2]}"/>
      </inertial></link></robot>"""
    p = tmp_path / "brick.urdf"
    p.write_text(txt)
    return p


def test_single_free_body_matches_rigid_body_formula(tmp_path):
    """1/m_eff = 1/m + (r x n)^T I_G^-1 (r x n), r = contact point - COM (world).

    A free brick (free-flyer base) with a rotated base pose; the contact is a point given
    in the body frame, the normal in world.
    """
    m, com, Id = 3.0, np.array([0.1, -0.05, 0.2]), np.array([0.2, 0.3, 0.15])
    f = _free_body_urdf(tmp_path, m, com, Id)
    pt = [0.3, 0.1, -0.2]
    n = np.array([0.3, -0.5, 0.8])
    s = Scenario.model_validate({
        "model": {"file": str(f), "floating_base": True},
        "configuration": {"base": {"x": 0.2, "roll_deg": 20, "pitch_deg": -35, "yaw_deg": 70}},
        "velocity": {"base_linear": [0.1, 0.2, -1.0], "base_angular": [0.5, -0.3, 0.2]},
        "obstacle": {"frame": "brick", "point": pt, "normal": n.tolist()},
    })
    setup = ri.ImpactSetup.from_scenario(s)
    e = setup.partition()
    R = pin.rpy.rpyToMatrix(*np.deg2rad([20, -35, 70]))
    nn = n / np.linalg.norm(n)
    r = R @ (np.array(pt) - com)
    I_w = R @ np.diag(Id) @ R.T
    rxn = np.cross(r, nn)
    assert 1.0 / e.m_eff_free == pytest.approx(1 / m + rxn @ np.linalg.solve(I_w, rxn), rel=1e-10)
    # single row: T_c = 1/2 m_eff v_n^2 with v_n from rigid-body kinematics
    vp = np.array([0.1, 0.2, -1.0]) + np.cross([0.5, -0.3, 0.2], R @ np.array(pt))
    assert e.v_n == pytest.approx(-nn @ vp, rel=1e-10)
    assert e.T_c_minus == pytest.approx(0.5 * e.m_eff_free * e.v_n**2, rel=1e-10)


def test_locking_all_joints_equals_one_rigid_body():
    """Rocker-bogie with rockers, bogies and wheels locked = one body of the total inertia.

    The composite COM and central inertia are summed here from the body placements and
    inertias (parallel-axis theorem), independently of the CRBA.
    """
    rv = rocker_bogie()
    joints = [n for n in rv.model.names[2:]]
    s = sc(RB, contacts={"ground_wheels": [], "locked": joints},
           configuration={"joints": {"rocker_left": 0.1, "rocker_right": -0.1,
                                     "bogie_left": -0.2},
                          "base": {"pitch_deg": 10, "yaw_deg": 25}})
    setup = ri.ImpactSetup.from_scenario(s)
    e = setup.partition()
    model = setup.model.model
    d = model.createData()
    pin.forwardKinematics(model, d, setup.q)
    mt, c = 0.0, np.zeros(3)
    for j in range(1, model.njoints):
        Ij = model.inertias[j]
        mt += Ij.mass
        c += Ij.mass * d.oMi[j].act(Ij.lever)
    c /= mt
    I = np.zeros((3, 3))
    for j in range(1, model.njoints):
        Ij = model.inertias[j]
        R = d.oMi[j].rotation
        g = d.oMi[j].act(Ij.lever) - c
        I += R @ Ij.inertia @ R.T + Ij.mass * (g @ g * np.eye(3) - np.outer(g, g))
    r = setup.contact_point - c
    rxn = np.cross(r, setup.normal)
    assert 1.0 / e.m_eff == pytest.approx(1 / mt + rxn @ np.linalg.solve(I, rxn), rel=1e-9)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # "all" held
def test_sweep_matches_individual_builds():
    """The batched beta sweep (M reused, only the obstacle row changes) = one build per beta."""
    for base in (ROVER2D, RB):
        betas = np.array([0.0, 15.0, 45.0, 75.0, 90.0])
        sw = sweep_energy(sc(base), np.deg2rad(betas))
        for k, b in enumerate(betas):
            e = energy_of(sc(base, obstacle={"beta_deg": b}))
            assert sw.T_c_minus[k] == pytest.approx(e.T_c_minus, rel=1e-9, abs=1e-12)
            assert sw.m_eff[k] == pytest.approx(e.m_eff, rel=1e-9)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # posed on purpose
@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")
def test_sweep_with_a_normal_along_the_wheel_axis_matches_individual_builds():
    """A rover rolled onto its side: the wheel axis is vertical, parallel to the beta = 0
    normal (a hit on the wheel's face). The sweep gave a NaN row there (166.8 kg where
    one build gives inf); it now takes the row assembly's rule, and agrees at every beta."""
    rolled = sc(RB, configuration={"base": {"roll_deg": 90.0}})
    betas = np.array([0.0, 1e-7, 30.0, 90.0])
    sw = sweep_energy(rolled, np.deg2rad(betas))
    assert np.all(np.isfinite(sw.T_c_minus)) and not np.any(np.isnan(sw.m_eff))
    for bad in ("abc", None, [[0.1], [0.2, 0.3]]):
        with pytest.raises(InputError, match="1-D array of finite angles"):
            sweep_energy(rolled, bad)
    for k, b in enumerate(betas):
        e = energy_of(sc(RB, configuration={"base": {"roll_deg": 90.0}},
                         obstacle={"beta_deg": b}))
        assert sw.T_c_minus[k] == pytest.approx(e.T_c_minus, rel=1e-9, abs=1e-12)
        assert sw.m_eff[k] == pytest.approx(e.m_eff, rel=1e-9)


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # posed on purpose
@pytest.mark.parametrize("builder", ["rover2d", "rocker_bogie"])
def test_urdf_export_loads_back_to_same_M_and_A(tmp_path, builder):
    """Export to URDF, load the file in a scenario: identical M, A, labels and v."""
    base = ROVER2D if builder == "rover2d" else RB
    params = {"suspension": "rocker", "middle_wheel": True} if builder == "rover2d" else {}
    mbm = rover2d(**params) if builder == "rover2d" else rocker_bogie()
    f = export_urdf(mbm, tmp_path / "rover.urdf")
    joints = ({"rocker": 0.2} if builder == "rover2d"  # the differential closed:
              else {"rocker_left": 0.1, "rocker_right": -0.1, "bogie_right": 0.3})
    a = sc(base, model={"name": builder, "params": params}, configuration={"joints": joints},
           contacts={"locked": [mbm.lockable_joints[0]]})
    b = sc(base, model={"file": str(f), "name": None}, configuration={"joints": joints},
           contacts={"locked": [mbm.lockable_joints[0]]})
    sa, sb = ri.ImpactSetup.from_scenario(a), ri.ImpactSetup.from_scenario(b)
    assert sa.labels == sb.labels
    np.testing.assert_allclose(sb.M, sa.M, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sb.A, sa.A, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(sb.v, sa.v)


def test_panda_tool_effective_mass_vs_finite_differences_and_aba():
    """Panda tool point: m_eff = 1/(n^T J M^-1 J^T n) with J by central differences of the
    point position and M^-1 column by column from ABA (pin.aba with unit torques, gravity
    removed), a route independent of CRBA and frame Jacobians."""
    pytest.importorskip("pinocchio")
    from roverimpact.models.robot import example_robot_file

    # example-robot-data is a test dependency: a missing package fails here, never skips
    urdf = example_robot_file("panda_description/urdf/panda.urdf")
    q_arm = {"panda_joint1": 0.3, "panda_joint2": -0.4, "panda_joint4": -2.0,
             "panda_joint6": 1.6, "panda_joint7": 0.7}
    n = np.array([0.2, -0.4, -0.9])
    pt = [0.0, 0.0, 0.05]
    s = Scenario.model_validate({
        "model": {"file": str(urdf)}, "configuration": {"joints": q_arm},
        "velocity": {"joints": {"panda_joint1": 0.5, "panda_joint2": 0.8}},
        "obstacle": {"frame": "panda_hand_tcp", "point": pt, "normal": n.tolist()},
    })
    setup = ri.ImpactSetup.from_scenario(s)
    e = setup.partition()
    model = setup.model.model
    d = model.createData()
    q = setup.q
    fid = model.getFrameId("panda_hand_tcp")
    J = np.zeros((3, model.nv))
    h = 1e-6
    for i in range(model.nv):
        dq = np.zeros(model.nv)
        dq[i] = h
        pos = []
        for sgn in (1, -1):
            pin.framesForwardKinematics(model, d, pin.integrate(model, q, sgn * dq))
            pos.append(d.oMf[fid].act(np.array(pt)))
        J[:, i] = (pos[0] - pos[1]) / (2 * h)
    z = np.zeros(model.nv)
    a0 = pin.aba(model, d, q, z, z).copy()
    Minv = np.column_stack([pin.aba(model, d, q, z, np.eye(model.nv)[i]) - a0
                            for i in range(model.nv)])
    nn = n / np.linalg.norm(n)
    jn = nn @ J
    assert e.m_eff_free == pytest.approx(1.0 / (jn @ Minv @ jn), rel=1e-6)
    assert e.v_n == pytest.approx(-(jn @ setup.v), rel=1e-6)


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("upd,match", [
    ({"configuration": {"joints": {"nope": 1.0}}}, "unknown joint 'nope'"),
    ({"obstacle": {"wheel": "middle"}}, "unknown wheel 'middle'"),
    ({"contacts": {"locked": ["bogie"]}}, "unknown joint 'bogie'"),
    ({"constraints": ["ground:left:normal"]}, "matches no candidate"),
])
def test_bad_names_raise_config_error(upd, match):
    with pytest.raises(ConfigError, match=match):
        ri.ImpactSetup.from_scenario(sc(ROVER2D, **upd))


@pytest.mark.parametrize("obstacle,match", [
    ({"wheel": "front", "beta_deg": 95.0}, r"\[0, 90\]"),
    ({"wheel": "front", "beta_deg": -1.0}, r"\[0, 90\]"),
    ({"wheel": "front", "normal": [0.0, 0.0, 0.0]}, "non-zero"),
    ({"wheel": "front", "beta_deg": 10.0, "normal": [1, 0, 0]}, "exactly one"),
    ({"wheel": "front", "beta_deg": 10.0, "colour": "red"}, "unknown key"),
])
def test_bad_obstacle_rejected_at_load(tmp_path, obstacle, match):
    import tomli_w

    p = tmp_path / "s.toml"
    p.write_text(tomli_w.dumps({**ROVER2D, "obstacle": obstacle}))
    with pytest.raises(ConfigError, match=match):
        load_scenario(p)


def test_bad_files(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("model = {name = 'rover2d'\n")
    with pytest.raises(ConfigError, match="malformed TOML"):
        load_scenario(p)
    u = tmp_path / "bad.urdf"
    u.write_text("<robot name='x'><link name='a'></robot>")
    with pytest.raises(ModelError, match="malformed XML"):
        ri.ImpactSetup.from_scenario(sc(ROVER2D, model={"file": str(u), "name": None}))
    with pytest.raises(ModelError, match="wheel_mass"):
        ri.ImpactSetup.from_scenario(sc(ROVER2D, model={"params": {"wheel_mass": -2.0}}))
    with pytest.raises(ModelError, match="wheel_radius"):
        ri.ImpactSetup.from_scenario(sc(RB, model={"params": {"wheel_radius": -0.1}}))
    # parameters of any sign, and switches: a string or None is one ModelError (numpy's
    # TypeError escaped), the string "false" is not false (it built a middle wheel)
    for model, match in (
            ({"params": {"com_x": "0.05 m"}}, r"com_x must be a finite number, got '0\.05 m' "
                                              r"\(write a plain number in SI units\)"),
            ({"params": {"middle_wheel": "false"}}, "middle_wheel must be true or false"),
    ):
        with pytest.raises(ModelError, match=match):
            ri.ImpactSetup.from_scenario(sc(ROVER2D, model=model))
    with pytest.raises(ModelError, match="front_x must be a finite number"):
        ri.ImpactSetup.from_scenario(sc(RB, model={"params": {"front_x": "0.3"}}))
    with pytest.raises(ModelError, match="chassis_com_above_pivot must be a finite number"):
        rocker_bogie(chassis_com_above_pivot=None)
    with pytest.raises(ModelError, match="expected the path of a URDF/MJCF file, got NoneType"):
        ri.load_robot(None)
    # exports into a folder that does not exist: one ConfigError, nothing created
    from roverimpact.models.export_mjcf import export_mjcf

    for export in (export_urdf, export_mjcf):
        with pytest.raises(ConfigError, match="no such folder"):
            export(rover2d(), tmp_path / "missing" / "r.xml")
    assert not (tmp_path / "missing").exists()


def test_held_rows_heavier_than_the_vehicle_warn():
    """Every candidate row held (constraints = "all", bilateral no-slip): m_eff of the
    2-D rover at a 60 deg face exceeds its 24 kg: a HeldRowsWarning names the rows; the
    automatic active set on the same impact does not warn."""
    import warnings

    from roverimpact.exceptions import HeldRowsWarning

    raw = {"model": {"name": "rover2d"}, "velocity": {"u": 0.3},
           "obstacle": {"wheel": "front", "beta_deg": 60.0}, "contacts": {"ground": "noslip"}}
    with pytest.warns(HeldRowsWarning, match=r"24 kg.*ground:rear:long"):
        en = ri.energy_of(ri.Scenario.model_validate({**raw, "constraints": "all"}))
    assert float(en.m_eff) > 24.0
    with warnings.catch_warnings():
        warnings.simplefilter("error", HeldRowsWarning)
        assert float(ri.energy_of(ri.Scenario.model_validate(raw)).m_eff) < 24.0
    with pytest.warns(HeldRowsWarning):
        ri.scenario.sweep_energy(ri.Scenario.model_validate({**raw, "constraints": "all"}),
                                 np.radians([30.0, 60.0]))


@pytest.mark.filterwarnings("ignore:m_eff = .* exceeds")  # the set jams the rover too
def test_noslip_held_contact_that_pulls_warns():
    """ground = "noslip" on the bumps example at beta = 60 deg: the frictionless active set,
    with the no-slip rows of its holding wheels kept as bilateral rows, needs a pulling
    normal impulse at the right middle wheel. Reference: G p = -A v with G = A M^-1 A^T
    (plain numpy, the 11 held rows independent; restitution 0, the default) gives
    p_n = -5.47 N s against the obstacle's 6.53 N s, T_c^- = 0.84 J; Coulomb friction with
    mu = inf (the no-slip rows in the impact problem) holds no pulling wheel, 0.265 J.
    A PullingContactWarning names the wheel and the impulse; the default ground, Coulomb
    and sweep_energy's batch over beta agree."""
    import warnings
    from pathlib import Path

    from roverimpact.exceptions import HeldRowsWarning, PullingContactWarning

    path = Path(__file__).parents[1] / "examples" / "rocker_bogie_on_bumps.toml"
    base = load_scenario(path).model_dump()
    base["obstacle"]["beta_deg"] = 60.0

    def with_ground(**contacts):
        d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in base.items()}
        d["contacts"] = {**d["contacts"], **contacts}
        return Scenario.model_validate(d)

    noslip = ri.ImpactSetup.from_scenario(with_ground(ground="noslip"))
    M, A, v = noslip.M, noslip.A, noslip.v
    p = np.linalg.solve(A @ np.linalg.solve(M, A.T), -(A @ v))
    i = noslip.labels.index("ground:right_middle:normal")
    assert p[i] == pytest.approx(-5.475, abs=2e-3)
    assert p[noslip.obstacle_row] == pytest.approx(6.532, abs=2e-3)
    with pytest.warns(PullingContactWarning,
                      match=r"ground:right_middle .*-5\.47 N s.*6\.53 N s.*coulomb.*mu = inf"):
        en = noslip.partition()
    assert float(en.T_c_minus) == pytest.approx(0.8402, abs=1e-4)
    with pytest.warns(PullingContactWarning, match=r"ground:right_middle .*-5\.47 N s"):
        sweep_energy(with_ground(ground="noslip"), np.radians([60.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", HeldRowsWarning)  # the pulling warning's base class
        for sc_ in (with_ground(ground="coulomb", mu=float("inf")), with_ground()):
            setup = ri.ImpactSetup.from_scenario(sc_)
            q = np.linalg.solve(setup.A @ np.linalg.solve(setup.M, setup.A.T),
                                -(setup.A @ setup.v))
            normal = [k for k, lb in enumerate(setup.labels) if lb.endswith(":normal")]
            assert q[normal].min() >= 0.0
            energy_of(setup)
            sweep_energy(sc_, np.radians([10.0, 30.0, 45.0, 60.0, 80.0]))
        assert float(energy_of(with_ground(ground="coulomb", mu=float("inf"))).T_c_minus
                     ) == pytest.approx(0.2646, abs=1e-4)


@pytest.mark.parametrize("model", [{"name": "rocker_bogie"},
                                   {"name": "rover2d", "params": {"suspension": "rocker"}}])
def test_T_c_at_equals_evaluate_then_partition(model):
    """``setup.T_c_at(q)`` (one compiled call) is ``partition(*setup.evaluate(q), v).T_c``
    to rounding, at the setup's q and at perturbed configurations; bad q is one error."""
    from roverimpact.exceptions import InputError

    wheel = "left_front" if model["name"] == "rocker_bogie" else "front"
    sc = Scenario.model_validate({"model": model, "velocity": {"u": 0.3},
                                  "obstacle": {"wheel": wheel, "beta_deg": 50.0}})
    setup = ri.ImpactSetup.from_scenario(sc)
    assert setup.T_c_at(setup.q) == pytest.approx(setup.partition().T_c_minus, rel=1e-13)
    rng = np.random.default_rng(5)
    mod = setup.model.model
    for _ in range(10):
        q = pin.integrate(mod, setup.q, 0.05 * rng.standard_normal(mod.nv))
        M, A = setup.evaluate(q)
        ref = ri.partition(M, A, setup.v, want_velocities=False).T_c
        assert setup.T_c_at(q) == pytest.approx(ref, rel=1e-13, abs=1e-300)
    with pytest.raises(ModelError, match="T_c_at takes one configuration"):
        setup.T_c_at(np.stack([setup.q, setup.q]))
    bad = setup.q.copy()
    bad[0] = np.nan
    with pytest.raises(InputError, match="q contains NaN"):
        setup.T_c_at(bad)


def test_setup_from_state_takes_columns_and_lists():
    """``from_state`` with q and v as columns of matrices (``Q[:, i]``, not C-contiguous)
    or lists gives the same setup, and ``T_c_at`` works on it (numba refused the column
    as the kernel's v); a setup made with ``dataclasses.replace`` and such a v too. NaN in
    q is named as such (it was "heading has no horizontal component")."""
    import dataclasses

    from roverimpact.exceptions import InputError

    sc = Scenario.model_validate({"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.2},
                                  "obstacle": {"wheel": "left_front", "beta_deg": 30.0}})
    ref = ri.ImpactSetup.from_scenario(sc)
    Q = np.zeros((len(ref.q), 3))
    V = np.zeros((len(ref.v), 3))
    Q[:, 1], V[:, 1] = ref.q, ref.v
    expected = ref.T_c_at(ref.q)
    for q, v in ((Q[:, 1], V[:, 1]), (list(ref.q), list(ref.v))):
        setup = ri.ImpactSetup.from_state(ref.model, q, v, obstacle=sc.obstacle,
                                          contacts=sc.contacts)
        assert setup.labels == ref.labels
        assert setup.T_c_at(Q[:, 1]) == pytest.approx(expected, rel=1e-13)
        assert float(setup.partition().T_c_minus) == pytest.approx(expected, rel=1e-12)
    replaced = dataclasses.replace(ref, v=V[:, 1])
    assert replaced.v.flags.c_contiguous
    assert replaced.T_c_at(ref.q) == pytest.approx(expected, rel=1e-13)
    bad = ref.q.copy()
    bad[3] = np.nan
    with pytest.raises(InputError, match="q contains NaN"):
        ri.ImpactSetup.from_state(ref.model, bad, ref.v, obstacle=sc.obstacle)


def test_no_approach_no_impact_energy(tmp_path):
    """A rover driving away from the face (u < 0, v_n < 0) has no impact: T_c^- = 0 and
    T_a = T from energy_of, sweep_energy and a study (one-scenario cases, angle groups and
    model-changing blocks), as the predicted peak force (0) and the traverse have it.
    Before, the partition's T_c^- of the receding velocity (1.47 J here, more than the
    approaching rover's 1.39 J) was reported. Reference: the unilateral impact map of the
    obstacle row, which finds no impact (T_c^- = 0, no impulse) for a receding contact."""
    from roverimpact.exceptions import InputError
    from roverimpact.studies import load_results, run_study
    from roverimpact.unilateral import unilateral_impact

    def sc(u, beta=45.0, **model):
        return Scenario.model_validate({"model": {"name": "rover2d", **model},
                                        "velocity": {"u": u},
                                        "obstacle": {"wheel": "front", "beta_deg": beta}})

    ahead, back = energy_of(sc(0.5)), energy_of(sc(-0.5))
    assert float(back.v_n) == pytest.approx(-float(ahead.v_n)) and float(ahead.v_n) > 0
    assert float(ahead.T_c_minus) > 0
    assert float(back.T_c_minus) == 0.0 and float(back.T_a) == float(back.T)
    setup = ri.ImpactSetup.from_scenario(sc(-0.5))
    imp = unilateral_impact(setup.M, setup.v, setup.A[[setup.obstacle_row]])
    assert not imp.impact and float(imp.T_c_minus) == 0.0 and float(imp.impulse[0]) == 0.0
    with pytest.raises(InputError, match="no impact"):
        unilateral_impact(setup.M, setup.v, setup.A[[setup.obstacle_row]], obstacle=0)
    betas = np.radians([20.0, 45.0, 70.0])
    sw_back, sw_ahead = sweep_energy(sc(-0.5), betas), sweep_energy(sc(0.5), betas)
    np.testing.assert_array_equal(sw_back.T_c_minus, 0.0)
    np.testing.assert_array_equal(sw_back.T_a, sw_back.T)
    assert (sw_ahead.T_c_minus > 0).all()
    study = {"name": "reverse", "base": sc(0.5).model_dump(exclude_none=True),
             "cases": [{"velocity.u": u, "obstacle.beta_deg": b, "model.params.h": h}
                       for u in (0.5, -0.5) for b in (30.0, 60.0) for h in (0.3, 0.35)]}
    df = load_results(run_study(study, tmp_path / "out").out_dir)[0]
    assert (df.loc[df["velocity.u"] < 0, "T_c_minus"] == 0.0).all()
    assert (df.loc[df["velocity.u"] > 0, "T_c_minus"] > 0.0).all()
    for _, row in df.iterrows():
        own = energy_of(sc(row["velocity.u"], row["obstacle.beta_deg"],
                           params={"h": row["model.params.h"]}))
        assert row["T_c_minus"] == pytest.approx(float(own.T_c_minus), rel=1e-12, abs=0.0)


def test_scenario_functions_take_dicts_paths_and_single_strings(tmp_path):
    """energy_of, ImpactSetup.from_scenario and sweep_energy take a Scenario, its dict or
    its TOML file (a dict raised AttributeError), with the same numbers; a typo in the
    dict is one ConfigError. from_state: q or v of another shape is one ModelError (an
    IndexError or a numpy matmul error before), obstacle and contacts may be dicts, and
    constraints = "ground:*" or also_hit = "rear" given as one string are one pattern /
    one wheel (they were iterated character by character: "'g' matches no candidate
    row")."""
    raw = {"model": {"name": "rover2d"}, "velocity": {"u": 0.4},
           "obstacle": {"wheel": "front", "beta_deg": 50.0}}
    path = tmp_path / "s.toml"
    path.write_text('[model]\nname = "rover2d"\n[velocity]\nu = 0.4\n'
                    '[obstacle]\nwheel = "front"\nbeta_deg = 50.0\n')
    ref = energy_of(Scenario.model_validate(raw))
    for given in (raw, path, str(path)):
        assert float(energy_of(given).T_c_minus) == float(ref.T_c_minus)
        assert ri.ImpactSetup.from_scenario(given).labels == \
            ri.ImpactSetup.from_scenario(Scenario.model_validate(raw)).labels
    np.testing.assert_array_equal(sweep_energy(raw, np.radians([30.0, 50.0])).T_c_minus,
                                  sweep_energy(path, np.radians([30.0, 50.0])).T_c_minus)
    with pytest.raises(ConfigError, match="beta"):
        energy_of({**raw, "obstacle": {"wheel": "front", "beta": 50.0}})
    with pytest.raises(ConfigError, match="expected a Scenario, a dict or the path"):
        energy_of(None)
    setup = ri.ImpactSetup.from_scenario(raw)
    sc = setup.scenario
    for q, v, match in ((setup.q[None], setup.v, r"q must have shape \(5,\)"),
                        (setup.q, setup.v[None], r"v must have shape \(5,\)")):
        with pytest.raises(ModelError, match=match):
            ri.ImpactSetup.from_state(setup.model, q, v, obstacle=sc.obstacle)
    as_dicts = ri.ImpactSetup.from_state(setup.model, setup.q, setup.v,
                                         obstacle=raw["obstacle"], contacts={})
    assert as_dicts.labels == setup.labels
    one = ri.ImpactSetup.from_state(setup.model, setup.q, setup.v, obstacle=sc.obstacle,
                                     constraints="ground:*")
    listed = ri.ImpactSetup.from_state(setup.model, setup.q, setup.v, obstacle=sc.obstacle,
                                       constraints=["ground:*"])
    assert one.labels == listed.labels and "ground:rear:normal" in one.labels
    both = ri.ImpactSetup.from_state(setup.model, setup.q, setup.v, obstacle=sc.obstacle,
                                     also_hit="rear")
    assert both.candidate_labels == ri.ImpactSetup.from_state(
        setup.model, setup.q, setup.v, obstacle=sc.obstacle, also_hit=["rear"]
    ).candidate_labels


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # posed on purpose
def test_the_built_in_differential_cannot_be_opened(tmp_path):
    """The rocker-bogie's differential (a built-in loop-closure row): one rocker turned
    by configuration.joints, or given a rate by velocity.joints, opens it and is one
    ConfigError naming the loop (it was accepted: 0.188 J against 0.188 J for the closed
    mechanism, and with a rate 0.207 J against 0.288 J). Both rockers set so that it is
    closed give what the same rover written as a plain URDF with a mimic differential
    gives with one rocker set (the mimic turns the other)."""
    from roverimpact.models import export_plain_urdf

    base = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.2},
            "obstacle": {"wheel": "left_front", "beta_deg": 30.0}}
    with pytest.raises(ConfigError, match=r"open the loop 'differential' by 0\.2 .*"
                                          r"\['rocker_left', 'rocker_right'\]"):
        energy_of({**base, "configuration": {"joints": {"rocker_left": 0.2}}})
    with pytest.raises(ConfigError, match=r"joint rates open the loop 'differential'"):
        energy_of({**base, "velocity": {"u": 0.2, "joints": {"rocker_left": 1.0}}})
    closed = energy_of({**base, "configuration": {"joints": {"rocker_left": 0.2,
                                                            "rocker_right": -0.2}},
                        "velocity": {"u": 0.2, "joints": {"rocker_left": 1.0,
                                                          "rocker_right": -1.0}}})
    plain = {**export_plain_urdf(rocker_bogie(), tmp_path / "rb.urdf"),
             "velocity": {"u": 0.2, "joints": {"rocker_left": 1.0}},
             "configuration": {"joints": {"rocker_left": 0.2}},
             "obstacle": base["obstacle"]}
    assert float(closed.T_c_minus) == pytest.approx(float(energy_of(plain).T_c_minus),
                                                    rel=1e-9)


def test_a_contact_that_cannot_move_along_its_normal_is_named():
    """An obstacle on a link fixed to the world, or a normal out of a planar rover's plane:
    the row is zero; one ConfigError names it (the partition said "unilateral row 1 is
    all zeros" without naming it)."""
    cases = (
        ({"model": {"file": "erd:panda"}, "velocity": {"joints": {"panda_joint1": 0.5}},
          "obstacle": {"frame": "panda_link0", "point": [0, 0, 0], "normal": [0, 0, 1]}},
         "obstacle:panda_link0:normal"),
        ({"model": {"name": "rover2d"}, "velocity": {"u": 0.5},
          "obstacle": {"wheel": "front", "normal": [0, 1, 0]}}, "obstacle:front:normal"),
    )
    for raw, label in cases:
        with pytest.raises(ConfigError, match=rf"contact rows \['{label}'\] are zero"):
            energy_of(raw)


def test_configurations_that_are_not_one_are_refused():
    """q whose base quaternion is not of unit norm (Pinocchio reads it as a rotation
    scaled by its squared norm: T_c_at gave 0.0793 J for 0.0542 with a quaternion of norm
    2, and took a zero quaternion for the identity) is one ModelError naming the joint, in
    T_c_at, evaluate (one item or a batch) and from_state; NaN in q passed to evaluate is
    one InputError (it returned M and A full of NaN). A quaternion off by 1e-9 (rounding)
    is accepted."""
    from roverimpact.exceptions import InputError

    setup = ri.ImpactSetup.from_scenario(sc(RB))
    ref = setup.T_c_at(setup.q)
    for scale in (2.0, 1.0001, 0.0):
        q = setup.q.copy()
        q[3:7] *= scale
        for call in (lambda q=q: setup.T_c_at(q), lambda q=q: setup.evaluate(q),
                     lambda q=q: setup.evaluate(np.stack([setup.q, q])),
                     lambda q=q: ri.ImpactSetup.from_state(setup.model, q, setup.v,
                                                           obstacle=setup.scenario.obstacle)):
            with pytest.raises(ModelError, match=r"the quaternion of joint 'root_joint' has "
                                                 rf"norm {scale * 1.0:g}"):
                call()
    q = setup.q.copy()
    q[3:7] *= 1 + 1e-9
    assert setup.T_c_at(q) == pytest.approx(ref, rel=1e-8)
    bad = setup.q.copy()
    bad[0] = np.nan
    for call in (lambda: setup.evaluate(bad), lambda: setup.evaluate(bad[None])):
        with pytest.raises(InputError, match="q contains NaN"):
            call()


def test_one_configurations_check_takes_the_sum_only_as_a_shortcut():
    """check_configuration's shortcut for one q (a finite sum of the coordinates) decides
    nothing by itself: +inf and -inf (a NaN sum) and inf in a revolute coordinate are
    refused as one configuration and in a batch, and finite coordinates whose sum
    overflows are checked like any other q (accepted with a unit quaternion, refused
    without)."""
    from roverimpact.exceptions import InputError
    from roverimpact.models.joints import check_configuration

    setup = ri.ImpactSetup.from_scenario(sc(RB))
    model = setup.model.model
    for k, x in ((0, np.inf), (8, -np.inf), (len(setup.q) - 1, np.nan)):
        q = setup.q.copy()
        q[k] = x
        q[1] = -x if np.isinf(x) else q[1]
        for bad in (q, q[None]):
            with pytest.raises(InputError, match="q contains NaN or inf"):
                check_configuration(model, bad)
    big = setup.q.copy()
    big[:2] = 1e308  # finite, the sum overflows
    check_configuration(model, big)
    big[3:7] *= 2.0
    with pytest.raises(ModelError, match="quaternion of joint 'root_joint' has norm 2"):
        check_configuration(model, big)


def test_coupled_joints_given_values_that_disagree(tmp_path):
    """Two joints coupled by a MuJoCo joint equality (jb = 0.2 - ja) both given in
    [configuration.joints] or [velocity.joints] with values that disagree: one ConfigError
    (the last one written won silently: ja = 0.3 became -0.1, its rate 1.0 became -1.0);
    values that agree are accepted."""
    xml = tmp_path / "eq.xml"
    xml.write_text(
        '<mujoco model="eq"><worldbody><body name="a"><joint name="ja" type="hinge" '
        'axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.02"/></body>'
        '<body name="b" pos="1 0 0"><joint name="jb" type="hinge" axis="0 1 0"/><geom '
        'type="capsule" fromto="0 0 0 -0.5 0 0" size="0.02"/></body></worldbody><equality>'
        '<joint joint1="jb" joint2="ja" polycoef="0.2 -1 0 0 0"/></equality></mujoco>')
    base = {"model": {"file": str(xml)}, "contacts": {"ground_wheels": []},
            "obstacle": {"frame": "b", "point": [-0.5, 0, 0], "normal": [0, 0, 1]}}
    with pytest.raises(ConfigError, match=r"configuration\.joints: ja = 0\.3 was changed to "
                                          r"-0\.1"):
        ri.ImpactSetup.from_scenario({**base, "configuration": {"joints": {"ja": 0.3,
                                                                           "jb": 0.3}},
                                      "velocity": {"joints": {"ja": 1.0}}})
    with pytest.raises(ConfigError, match=r"velocity\.joints: ja = 1 was changed to -1"):
        ri.ImpactSetup.from_scenario({**base, "velocity": {"joints": {"ja": 1.0, "jb": 1.0}}})
    ok = ri.ImpactSetup.from_scenario({**base, "configuration": {"joints": {"ja": 0.3,
                                                                            "jb": -0.1}},
                                       "velocity": {"joints": {"ja": 1.0, "jb": -1.0}}})
    ia, ib = (ok.model.model.joints[ok.model.model.getJointId(n)].idx_q for n in ("ja", "jb"))
    assert ok.q[ia] == pytest.approx(0.3) and ok.q[ib] == pytest.approx(-0.1)


def test_fixed_base_on_a_file_with_a_free_root(tmp_path):
    """model.base.kind = "fixed" on an MJCF file whose root body has a free joint welds
    it where the file places it, as model.floating_base = false does. Reference: the
    effective mass 1 / (n^T J M^-1 J^T n) of the hit point, from Pinocchio on the same
    text without the <freejoint/> (an arm on a pitched base, hit at its tip)."""
    text = FREE_ROOT_ARM_MJCF
    (tmp_path / "free.xml").write_text(text)
    (tmp_path / "welded.xml").write_text(text.replace("<freejoint name='fly'/>", ""))
    ref = ri.load_robot(tmp_path / "welded.xml").model
    data = ref.createData()
    q, v = np.array([0.4]), np.array([1.5])
    pin.computeJointJacobians(ref, data, q)
    pin.framesForwardKinematics(ref, data, q)
    tip = pin.SE3(np.eye(3), np.array([0.4, 0.0, 0.0]))
    J = np.reshape(pin.getFrameJacobian(ref, data, ref.getJointId("j"), tip,
                                        pin.LOCAL_WORLD_ALIGNED), (6, -1))[:3]
    n = np.array([0.0, 0.0, 1.0])  # the face's normal, out of the obstacle: v_n = -n J v
    if n @ J @ v > 0:
        n = -n
    M = pin.crba(ref, data, q)
    m_ref = 1.0 / float(n @ J @ np.linalg.solve(M, J.T) @ n)
    f = str(tmp_path / "free.xml")
    for model in ({"file": f, "base": {"kind": "fixed"}}, {"file": f, "floating_base": False}):
        sc = {"model": model, "configuration": {"joints": {"j": 0.4}},
              "velocity": {"joints": {"j": 1.5}},
              "obstacle": {"frame": "arm", "point": [0.4, 0, 0], "normal": n.tolist()}}
        e = energy_of(sc)
        assert float(e.m_eff_free) == pytest.approx(m_ref, rel=1e-10)
        assert float(e.T_c_minus) == pytest.approx(0.5 * m_ref * float(n @ J @ v) ** 2,
                                                   rel=1e-10)


@pytest.mark.parametrize("upd, where", [
    ({"obstacle": {"beta_deg": True}}, "obstacle.beta_deg"),
    ({"velocity": {"u": False}}, "velocity.u"),
    ({"configuration": {"base": {"roll_deg": True}}}, "configuration.base.roll_deg"),
    ({"obstacle": {"beta_deg": None, "frame": "chassis", "wheel": None,
                   "point": [0.0, True, 0.0], "normal": [1.0, 0.0, 0.0]}}, "obstacle.point.1"),
    ({"contacts": {"mu": {"ground": True}}}, "contacts.mu"),
])
def test_a_boolean_is_not_a_number(upd, where):
    """TOML's true where a number belongs: pydantic read beta_deg = true as 1 degree."""
    with pytest.raises(ConfigError, match=rf"{re.escape(where)}.*got (true|false), a boolean"):
        ri.energy_of(raw(ROVER2D, **upd))


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # "all" held
def test_booleans_where_the_schema_takes_them():
    """Boolean options, and builder parameters (which may be boolean), are untouched."""
    e = ri.energy_of(sc(ROVER2D, model={"params": {"middle_wheel": True}}))
    assert np.isfinite(float(e.T_c_minus))


def test_ground_wheels_off_the_ground_are_named():
    """On flat ground (no [terrain]) a ground wheel off z = 0 in [configuration] (the base
    raised 5 cm, or a suspension joint set) is held as if it touched: a GroundGapWarning
    names it with its gap (the rover raised 5 cm: every wheel 0.05 m above). At the
    nominal pose none is off."""
    import warnings

    from roverimpact.exceptions import GroundGapWarning

    nominal = ri.rocker_bogie().params["q_nominal"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", GroundGapWarning)
        ri.ImpactSetup.from_scenario(sc(RB))
    with pytest.warns(GroundGapWarning, match=r"'right_front' 0\.05 m above") as rec:
        ri.ImpactSetup.from_scenario(sc(RB, configuration={"base": {"z": nominal[2] + 0.05}}))
    assert sum("0.05 m above" in str(r.message) for r in rec) == 1
    assert str(rec[0].message).count("m above") == 5  # the ground wheels: all but the hit one


def test_threads_sharing_a_setup_get_one_thread_s_results(monkeypatch):
    """Two threads calling T_c_at, evaluate (one q and a batch) and sweep_energy on one
    setup get what one thread gets: each thread has its own Pinocchio data, never used by
    two passes at once. Before, both used the setup's one data, and the compiled kernels
    read it with the GIL released while the other thread's Pinocchio pass rewrote it: now
    and then a wrong T_c or M (a few of 12 000 calls in a scratch run). Here every
    Pinocchio pass sleeps 2 ms, so passes of the two threads on one data would overlap."""
    import threading
    import time

    setup = ri.ImpactSetup.from_scenario(sc(RB))
    model = setup.model.model
    rng = np.random.default_rng(3)
    Q = [pin.integrate(model, setup.q, 0.1 * rng.standard_normal(model.nv)) for _ in range(2)]
    beta = np.radians([10.0, 50.0])

    def calls(q):
        return (setup.T_c_at(q), *setup.evaluate(q), *setup.evaluate(np.stack([q, Q[0]])),
                sweep_energy(setup, beta).T_c_minus)

    expected = [calls(q) for q in Q]
    inside: dict[int, int] = {}
    most = [0]
    used: dict[int, set] = {0: set(), 1: set()}
    who = threading.local()
    jacobians = pin.computeJointJacobians

    def slow(model_, data_, q):
        key = id(data_)
        inside[key] = inside.get(key, 0) + 1
        most[0] = max(most[0], inside[key])
        used[getattr(who, "i", 0)].add(key)
        try:
            time.sleep(0.002)  # the other thread runs meanwhile
            return jacobians(model_, data_, q)
        finally:
            inside[key] -= 1

    monkeypatch.setattr(pin, "computeJointJacobians", slow)
    got: list[list] = [[], []]

    def work(i):
        who.i = i
        for _ in range(4):
            got[i].append(calls(Q[i]))

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert most[0] == 1  # never two passes on one data at once
    assert not used[0] & used[1]  # each thread its own data
    for i in range(2):
        assert len(got[i]) == 4
        for res in got[i]:
            for a, b in zip(res, expected[i], strict=True):
                np.testing.assert_array_equal(a, b)


def test_a_setup_pickles_with_its_own_data_and_lock():
    """A pickled setup (a Dask task's argument) comes back with its own Pinocchio data and
    lock and gives the same T_c_at."""
    import pickle

    setup = ri.ImpactSetup.from_scenario(sc(RB))
    copy = pickle.loads(pickle.dumps(setup))
    assert copy._cs.lock is not setup._cs.lock and copy._cs.data is not setup._cs.data
    assert copy.T_c_at(setup.q) == setup.T_c_at(setup.q)
