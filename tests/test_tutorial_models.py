"""The tutorial's own rovers (docs/tutorial-own-rover.md), checked against references
outside the scenario pipeline.

Sawppy-like URDF (examples/models/sawppy_like.urdf + examples/sawppy_like_beta.toml):

* it loads with the load-time MuJoCo M(q) check passed; its total mass is the sum of the
  file's ``<mass>`` elements (read here with ElementTree) and each turnbuckle carries its
  0.12 kg in the tree;
* the two turnbuckle point loops close at the scenario's configuration (< 1e-9 m) and
  leave the differential one degree of freedom;
* the wheels roll: the spin rate of each continuous wheel joint is u / r and the rim
  point touching the ground has zero velocity (Pinocchio frame velocities, not the
  scenario's rows);
* the steering locks are active rows for every beta of a sweep;
* T_c^- over beta: the closed forms that hold for any system (v_n = u sin beta,
  T_c^- = 1/2 m_eff v_n^2 when v is admissible for the other rows, the bounds
  1/2 m_eff_free v_n^2 <= T_c^- <= T, more rows never lower T_c^-), and the shape (see
  ``test_sweep_over_beta_is_plausible``);
* independent check 1: the brace, turnbuckle and right rocker rates eliminated by hand
  (velocity map S derived on paper from the geometry at the nominal pose) give the same
  T_c^- and m_eff as the loop rows, to 1e-10;
* independent check 2: at a closed configuration away from the nominal one (left rocker
  up 0.2 rad, closed by Newton on a residual written here from frame placements), the
  loop rows equal central finite differences of that residual, and T_c^- with either
  rows agrees to 1e-8; the turnbuckle keeps its length (exact loop, not linearised);
* the distance kind: the turnbuckles as massless rods (distance loops, no turnbuckle
  links) are the limit of the point-loop model whose turnbuckle mass goes to zero.

MJCF rover (examples/mjcf_rover.xml + examples/mjcf_rover_beta.toml): M, the rows and
T_c^- against the closed-form planar model (chassis on x, z, pitch; two wheels).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.scenario import ImpactSetup, Scenario, load_scenario
from roverimpact.scenario.build import scenario_model

ROOT = Path(__file__).resolve().parents[1]
SAWPPY = ROOT / "examples" / "sawppy_like_beta.toml"
URDF = ROOT / "examples" / "models" / "sawppy_like.urdf"
MJCF = ROOT / "examples" / "mjcf_rover_beta.toml"
STEER = ("steer_left_front", "steer_left_rear", "steer_right_front", "steer_right_rear")
R_WHEEL, U = 0.06, 0.3
L_TB = 0.18                                     # turnbuckle length [m]
TAB = {"left": (0.12, -0.02, 0.10), "right": (0.12, 0.02, 0.10)}   # in the rocker frame


@pytest.fixture(scope="module")
def sc():
    return load_scenario(SAWPPY)


@pytest.fixture(scope="module")
def setup(sc):
    return ImpactSetup.from_scenario(sc)


def _iv(model, name):
    return model.joints[model.getJointId(name)].idx_v


# ------------------------------------------------------------------------------ loading
def test_urdf_loads_with_the_mujoco_check_and_keeps_every_mass(setup):
    pytest.importorskip("mujoco")
    mbm = setup.model
    assert mbm.params["mujoco_check"] == "passed"
    model = mbm.model
    urdf_mass = sum(float(m.get("value")) for m in ET.parse(URDF).getroot().iter("mass"))
    assert urdf_mass == pytest.approx(14.84, abs=1e-12)          # the file's comment
    assert sum(Y.mass for Y in model.inertias) == pytest.approx(urdf_mass, rel=1e-14)
    for side in ("left", "right"):
        Y = model.inertias[model.getJointId(f"turnbuckle_{side}_pitch")]
        assert Y.mass == pytest.approx(0.12, abs=1e-15)
        np.testing.assert_allclose(Y.lever, [L_TB / 2, 0.0, 0.0], atol=1e-15)
        # the cross link of the universal joint is massless
        assert model.inertias[model.getJointId(f"turnbuckle_{side}_yaw")].mass == 0.0
    # every wheel touches z = 0 at the scenario's configuration
    data = model.createData()
    pin.framesForwardKinematics(model, data, setup.q)
    for w in mbm.wheels:
        assert data.oMf[model.getFrameId(w.frame)].translation[2] == pytest.approx(
            R_WHEEL, abs=1e-14)


def test_the_loops_close_and_leave_the_differential_one_degree_of_freedom(setup):
    mbm = setup.model
    phi, J = mbm.loop_closure(setup.q)
    assert phi.shape == (6,) and np.max(np.abs(phi)) < 1e-9
    assert [lab for lab in setup.labels if lab.startswith("loop:")] == [
        f"loop:turnbuckle_{s}:{c}" for s in ("left", "right") for c in "xyz"]
    model = mbm.model
    cols = [_iv(model, n) for n in ("rocker_left_joint", "rocker_right_joint", "brace_joint",
                                    "turnbuckle_left_yaw", "turnbuckle_left_pitch",
                                    "turnbuckle_right_yaw", "turnbuckle_right_pitch")]
    assert np.linalg.matrix_rank(J) == 6
    assert np.abs(np.delete(J, cols, axis=1)).max() < 1e-12    # no other joint in the loops
    assert len(cols) - np.linalg.matrix_rank(J[:, cols]) == 1


def test_wheels_roll_at_u(sc, setup):
    """The continuous wheel joints spin at u / r, and the rim point on the ground stands
    still: v_p = v_c + omega x (p - c) from Pinocchio's frame velocity."""
    mbm = setup.model
    model = mbm.model
    data = model.createData()
    pin.forwardKinematics(model, data, setup.q, setup.v)
    pin.updateFramePlacements(model, data)
    assert len(mbm.wheels) == 6
    for w in mbm.wheels:
        assert model.joints[model.getJointId(w.spin)].nq == 2        # continuous
        assert setup.v[_iv(model, w.spin)] == pytest.approx(sc.velocity.u / R_WHEEL, rel=1e-15)
        fid = model.getFrameId(w.frame)
        tw = pin.getFrameVelocity(model, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        v_p = tw.linear + np.cross(tw.angular, [0.0, 0.0, -R_WHEEL])
        np.testing.assert_allclose(v_p, 0.0, atol=1e-14)
        assert tw.linear[0] == pytest.approx(U, rel=1e-14)


# ------------------------------------------------------------------------------- sweep
def test_steering_locks_are_active_rows_for_every_beta(sc, setup):
    model = setup.model.model
    for jn in STEER:
        i = setup.labels.index(f"lock:{jn}")
        row = np.zeros(model.nv)
        row[_iv(model, jn)] = 1.0
        np.testing.assert_array_equal(setup.A[i], row)
    for beta in np.arange(0.0, 91.0, 10.0):
        labels = ImpactSetup.from_scenario(sc.with_beta(float(beta))).labels
        assert all(f"lock:{jn}" in labels for jn in STEER)


def test_sweep_over_beta_is_plausible(sc, setup):
    """What is checked, and why.

    Theorems (any M, A, v): v_n = u sin(beta) for a wheel rolling at u; v is admissible
    for every row but the obstacle's (rolling wheels, closed loops, locked steering), so
    T_c^- = 1/2 m_eff v_n^2 with m_eff the effective mass with the other rows held; one
    row gives 1/2 m_eff_free v_n^2 <= T_c^- and a projection gives T_c^- <= T; holding
    more rows ("all" against the contacts that hold, "auto") never lowers T_c^-.

    Shape (plausibility, not a reference): T_c^- = 0 at beta = 0, rises strictly up to
    55 deg (v_n and m_eff both grow), and has a single maximum on [0, 90] deg; beyond it
    the face turns vertical and the bogie lets the front wheel rise, so the effective
    mass falls. The built-in rocker-bogie and DETC2015-47747 Fig. 2 have the same shape;
    the simulated F_max of examples/study_sawppy_beta.toml follows it (Spearman 0.98,
    printed by examples/own_rover_tutorial.py).
    """
    deg = np.arange(0.0, 91.0, 5.0)
    e = ri.sweep_energy(setup, np.deg2rad(deg))
    np.testing.assert_allclose(e.v_n, U * np.sin(np.deg2rad(deg)), atol=1e-14)
    T_c = np.asarray(e.T_c_minus)
    np.testing.assert_allclose(T_c, 0.5 * e.m_eff * e.v_n**2, rtol=1e-9, atol=1e-15)
    assert T_c[0] < 1e-15
    assert np.all(T_c >= 0.5 * e.m_eff_free * e.v_n**2 * (1 - 1e-12))
    assert np.all(T_c <= e.T * (1 + 1e-12))
    e_all = ri.sweep_energy(ImpactSetup.from_scenario(sc.model_copy(update={
        "constraints": "all"})), np.deg2rad(deg))
    assert np.all(T_c <= e_all.T_c_minus * (1 + 1e-12))
    assert np.all(np.diff(T_c[deg <= 55.0]) > 0)
    k = int(np.argmax(T_c))
    assert 55.0 <= deg[k] <= 75.0
    assert np.all(np.diff(T_c[:k + 1]) > 0) and np.all(np.diff(T_c[k:]) < 0)
    # the scenario's own beta (45 deg) is the sweep's
    assert float(setup.partition().T_c_minus) == pytest.approx(T_c[deg == 45.0][0], rel=1e-12)


# -------------------------------------------------------------- independent check 1: S
def _hand_velocity_map(model) -> tuple[np.ndarray, list[int]]:
    """v = S v_r with the dependent rates eliminated by hand (nominal pose, every joint at
    0: brace end at (0, +-0.15, 0) from the brace pivot, turnbuckles along x (L = 0.18 m),
    tabs at (0.12, -+0.02, 0.10) from the rocker pivots; rates by the right-hand rule):

        brace end      phi' e_z x (0, +-0.15, 0)          = (-+0.15 phi', 0, 0)
        turnbuckle end + ((phi' + psi') e_z + chi' e_y) x (L, 0, 0)
                                                          = (0, L (phi' + psi'), -L chi')
        rocker tab     theta' e_y x (0.12, -+0.02, 0.10)  = (0.10 theta', 0, -0.12 theta')

    left:  -0.15 phi' = 0.10 theta_l',  psi_l' = -phi',  L chi_l' = 0.12 theta_l'
    right:  0.15 phi' = 0.10 theta_r',  psi_r' = -phi',  L chi_r' = 0.12 theta_r'
    so phi' = -2/3 theta_l', theta_r' = -theta_l', psi_l' = psi_r' = 2/3 theta_l',
    chi_l' = 2/3 theta_l', chi_r' = -2/3 theta_l'.
    """
    c = {"brace_joint": -2 / 3, "turnbuckle_left_yaw": 2 / 3, "turnbuckle_left_pitch": 2 / 3,
         "turnbuckle_right_yaw": 2 / 3, "turnbuckle_right_pitch": -2 / 3,
         "rocker_right_joint": -1.0}
    dep = [_iv(model, n) for n in c]
    keep = [i for i in range(model.nv) if i not in dep]
    S = np.zeros((model.nv, len(keep)))
    S[keep, np.arange(len(keep))] = 1.0
    col = keep.index(_iv(model, "rocker_left_joint"))
    for name, k in c.items():
        S[_iv(model, name), col] = k
    return S, keep


def test_hand_elimination_gives_the_same_m_eff_and_T_c(sc, setup):
    model = setup.model.model
    S, keep = _hand_velocity_map(model)
    loop = [i for i, lab in enumerate(setup.labels) if lab.startswith("loop:")]
    assert np.abs(setup.A[loop] @ S).max() < 1e-14             # S spans the loops' null space
    others = [i for i in range(len(setup.labels)) if i not in loop]
    A_r = setup.A[others] @ S
    M_r = S.T @ setup.M @ S
    v_r = setup.v[keep]
    np.testing.assert_allclose(S @ v_r, setup.v, atol=0)        # v is admissible
    obs = others.index(setup.obstacle_row)
    p = ri.partition(M_r, A_r, v_r)
    e = setup.partition()
    assert float(p.T_c) == pytest.approx(float(e.T_c_minus), rel=1e-10)
    held = np.delete(A_r, obs, axis=0)
    m_eff = ri.effective_mass(M_r, A_r[obs], held=held)
    assert float(m_eff) == pytest.approx(float(e.m_eff), rel=1e-10)
    # and over beta, all candidate rows held
    deg = np.arange(5.0, 91.0, 5.0)
    s_all = ImpactSetup.from_scenario(sc.model_copy(update={"constraints": "all"}))
    e_all = ri.sweep_energy(s_all, np.deg2rad(deg))
    for b, t_c in zip(deg, e_all.T_c_minus, strict=True):
        s_b = ImpactSetup.from_scenario(sc.model_copy(update={"constraints": "all"})
                                        .with_beta(float(b)))
        o = [i for i, lab in enumerate(s_b.labels) if not lab.startswith("loop:")]
        assert float(ri.partition(S.T @ s_b.M @ S, s_b.A[o] @ S, v_r).T_c) == pytest.approx(
            float(t_c), rel=1e-10)


# --------------------------------------------------- independent check 2: finite differences
DEP = ("brace_joint", "turnbuckle_left_yaw", "turnbuckle_left_pitch", "turnbuckle_right_yaw",
       "turnbuckle_right_pitch", "rocker_right_joint")


def _residual(model, data, q) -> np.ndarray:
    """Turnbuckle end minus rocker tab, both sides (world) [m], from frame placements."""
    pin.framesForwardKinematics(model, data, q)
    out = []
    for side in ("left", "right"):
        a = data.oMf[model.getFrameId(f"turnbuckle_{side}")].act(np.array([L_TB, 0.0, 0.0]))
        b = data.oMf[model.getFrameId(f"rocker_{side}")].act(np.array(TAB[side]))
        out.append(a - b)
    return np.concatenate(out)


def _set_angle(model, q, name, theta) -> np.ndarray:
    q = q.copy()
    j = model.joints[model.getJointId(name)]
    if j.nq == 2:                                   # continuous: (cos, sin)
        q[j.idx_q:j.idx_q + 2] = np.cos(theta), np.sin(theta)
    else:
        q[j.idx_q] = theta
    return q


def _angle(model, q, name) -> float:
    j = model.joints[model.getJointId(name)]
    return float(np.arctan2(q[j.idx_q + 1], q[j.idx_q]) if j.nq == 2 else q[j.idx_q])


def _close(model, q, theta_left) -> np.ndarray:
    """Newton on the residual above, finite-difference Jacobian in the six angles."""
    data = model.createData()
    q = _set_angle(model, q, "rocker_left_joint", theta_left)
    for _ in range(30):
        r = _residual(model, data, q)
        if np.max(np.abs(r)) < 1e-15:
            break
        th = np.array([_angle(model, q, n) for n in DEP])
        J = np.empty((6, 6))
        for k in range(6):
            dq = [_set_angle(model, q, DEP[k], th[k] + s * 1e-7) for s in (1, -1)]
            J[:, k] = (_residual(model, data, dq[0]) - _residual(model, data, dq[1])) / 2e-7
        th = th + np.linalg.solve(J, -r)
        for n, t in zip(DEP, th, strict=True):
            q = _set_angle(model, q, n, t)
    return q


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.GroundGapWarning")  # posed on purpose
def test_loop_rows_are_finite_differences_of_the_residual_away_from_the_nominal_pose(sc):
    mbm = scenario_model(sc)
    model = mbm.model
    base = ImpactSetup.from_scenario(sc)
    qc = _close(model, base.q, 0.2)
    data = model.createData()
    assert np.max(np.abs(_residual(model, data, qc))) < 1e-14
    # exact loop: each turnbuckle keeps its length between its two ball centres
    pin.framesForwardKinematics(model, data, qc)
    for side, y in (("left", 0.15), ("right", -0.15)):
        end = data.oMf[model.getFrameId("brace")].act(np.array([0.0, y, 0.0]))
        tab = data.oMf[model.getFrameId(f"rocker_{side}")].act(np.array(TAB[side]))
        assert np.linalg.norm(tab - end) == pytest.approx(L_TB, abs=1e-14)
    # the differential is not the linear theta_r = -theta_l: 14 mrad apart at 0.2 rad
    assert abs(_angle(model, qc, "rocker_right_joint") + 0.2) > 1e-2
    # the scenario, given those joint values by name, reproduces the closed pose
    joints = {n: _angle(model, qc, n) for n in (*DEP, "rocker_left_joint")}
    sc_c = sc.model_copy(update={"configuration": sc.configuration.model_copy(
        update={"joints": joints}), "constraints": "all"})
    s = ImpactSetup.from_scenario(sc_c)
    np.testing.assert_allclose(s.q, qc, atol=1e-15)
    phi, J = s.model.loop_closure(s.q)
    assert np.max(np.abs(phi)) < 1e-14
    h = 1e-6
    J_fd = np.empty((6, model.nv))
    for k in range(model.nv):
        e_k = np.zeros(model.nv)
        e_k[k] = h
        J_fd[:, k] = (_residual(model, data, pin.integrate(model, s.q, e_k))
                      - _residual(model, data, pin.integrate(model, s.q, -e_k))) / (2 * h)
    np.testing.assert_allclose(J, J_fd, atol=1e-9)
    loop = [i for i, lab in enumerate(s.labels) if lab.startswith("loop:")]
    A_fd = s.A.copy()
    A_fd[loop] = J_fd
    t_rows = float(s.partition().T_c_minus)
    t_fd = float(ri.partition(s.M, A_fd, s.v).T_c)
    assert t_rows > 0.05
    assert t_fd == pytest.approx(t_rows, rel=1e-8)


# ---------------------------------------------------------------- the distance kind
def _scaled_urdf(tmp_path, eps: float | None) -> Path:
    """The URDF with the turnbuckles' mass and inertia times ``eps``, or (None) without the
    turnbuckle links at all."""
    tree = ET.parse(URDF)
    root = tree.getroot()
    for el in list(root):
        name = el.get("name", "")
        if not name.startswith("turnbuckle_"):
            continue
        if eps is None:
            root.remove(el)
        elif el.tag == "link" and el.find("inertial") is not None:
            inert = el.find("inertial")
            m = inert.find("mass")
            m.set("value", repr(float(m.get("value")) * eps))
            I = inert.find("inertia")
            for k, val in I.attrib.items():
                I.set(k, repr(float(val) * eps))
    path = tmp_path / f"sawppy_{eps}.urdf"
    tree.write(path)
    return path


def test_massless_rod_distance_loops_are_the_light_turnbuckle_limit(sc, tmp_path):
    """Distance loops (length taken from the configuration) on the URDF without the
    turnbuckle links = point loops with the turnbuckle mass scaled by eps -> 0: the
    turnbuckles' rates are fixed by the loops, so their energy is O(eps)."""
    raw = sc.model_dump(mode="json", exclude_none=True)
    raw["model"]["file"] = str(_scaled_urdf(tmp_path, None))
    raw["contacts"]["loops"] = [
        {"name": f"rod_{s}", "kind": "distance", "frame_a": "brace", "point_a": [0.0, y, 0.0],
         "frame_b": f"rocker_{s}", "point_b": list(TAB[s])}
        for s, y in (("left", 0.15), ("right", -0.15))]
    rods = ImpactSetup.from_scenario(Scenario.model_validate(raw))
    phi, J = rods.model.loop_closure(rods.q)
    assert np.max(np.abs(phi)) < 1e-15 and J.shape[0] == 2
    t_rod = float(rods.partition().T_c_minus)
    full = float(ImpactSetup.from_scenario(sc).partition().T_c_minus)
    for eps in (1e-5, 1e-6):
        raw_e = sc.model_dump(mode="json", exclude_none=True)
        raw_e["model"]["file"] = str(_scaled_urdf(tmp_path, eps))
        t_eps = float(ImpactSetup.from_scenario(Scenario.model_validate(raw_e))
                      .partition().T_c_minus)
        assert abs(t_eps - t_rod) <= 2 * eps * abs(full - t_rod) + 1e-12 * full
    assert full > t_rod * 1.01                      # the 0.24 kg of turnbuckles count


def test_distance_loop_keeps_its_configured_length(sc, tmp_path):
    """A distance loop without length keeps the distance of its points in the scenario's
    configuration; with a length, phi = distance - length, and a loop the configuration
    leaves open by more than 1e-6 m is refused."""
    from roverimpact.exceptions import ConfigError

    raw = sc.model_dump(mode="json", exclude_none=True)
    raw["model"]["file"] = str(_scaled_urdf(tmp_path, None))
    loop = {"name": "rod", "kind": "distance", "frame_a": "brace", "point_a": [0.0, 0.15, 0.0],
            "frame_b": "rocker_left", "point_b": list(TAB["left"])}
    raw["contacts"]["loops"] = [loop]
    s = ImpactSetup.from_scenario(Scenario.model_validate(raw))
    assert abs(s.model.loop_closure(s.q)[0][0]) < 1e-15
    raw["contacts"]["loops"] = [loop | {"length": L_TB + 5e-7}]
    s = ImpactSetup.from_scenario(Scenario.model_validate(raw))
    assert s.model.loop_closure(s.q)[0][0] == pytest.approx(-5e-7, abs=1e-15)
    raw["contacts"]["loops"] = [loop | {"length": 0.2}]
    with pytest.raises(ConfigError, match=r"loop:rod is open by 0\.02 m"):
        ImpactSetup.from_scenario(Scenario.model_validate(raw))


# ------------------------------------------------------------------------- MJCF rover
@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # rear held
def test_mjcf_rover_against_the_closed_form_planar_model():
    """examples/mjcf_rover.xml as a planar system q = (x, z, pitch, spin_f, spin_r):
    chassis 20 kg (box 0.7 x 0.4 x 0.15 m, I_yy = m (a^2 + c^2) / 12) at the pitch axis,
    wheels 2 kg (J = m r^2 / 2, r = 0.15 m) at (+-0.3, -0.2) from it. Rows: the rear rim
    point's z velocity, and n . v_p at the front rim point p = c - r n."""
    sc = load_scenario(MJCF)
    m_c, m_w, r, xw, zw = 20.0, 2.0, 0.15, 0.3, -0.2
    I_c = m_c * (0.7**2 + 0.15**2) / 12
    J_w = m_w * r**2 / 2
    M = np.zeros((5, 5))
    M[0, 0] = M[1, 1] = m_c + 2 * m_w
    M[0, 2] = M[2, 0] = 2 * m_w * zw                # x' couples with pitch through the wheels
    M[2, 2] = I_c + 2 * (m_w * (xw**2 + zw**2) + J_w)
    M[2, 3] = M[3, 2] = M[2, 4] = M[4, 2] = M[3, 3] = M[4, 4] = J_w
    v = np.array([0.5, 0.0, 0.0, 0.5 / r, 0.5 / r])

    def row(x, nrm):
        """n . v_p at the rim point p = c - r n of the wheel at (x, zw): pitch rate theta
        moves p by theta e_y x p = theta (p_z, -p_x); the spin moves it by
        psi e_y x (-r n), which is orthogonal to n."""
        px, pz = x - r * nrm[0], zw - r * nrm[1]
        return np.array([nrm[0], nrm[1], nrm[0] * pz - nrm[1] * px, 0.0, 0.0])

    a_gnd = row(-xw, (0.0, 1.0))                     # rear: [0, 1, 0.3, 0, 0]
    np.testing.assert_allclose(a_gnd, [0.0, 1.0, xw, 0.0, 0.0], atol=1e-15)
    for beta in (20.0, 45.0, 80.0):
        b = np.deg2rad(beta)
        a_obs = row(xw, (-np.sin(b), np.cos(b)))
        assert -a_obs @ v == pytest.approx(0.5 * np.sin(b), rel=1e-14)
        for cons, A in (("all", np.array([a_gnd, a_obs])), (["obstacle:*"], a_obs[None])):
            s = ImpactSetup.from_scenario(sc.with_beta(beta).model_copy(
                update={"constraints": cons}))
            np.testing.assert_allclose(s.v, v, rtol=1e-15)
            np.testing.assert_allclose(s.M, M, atol=1e-12)
            np.testing.assert_allclose(s.A, A, atol=1e-14)
            t_ref = float(ri.partition(M, A, v).T_c)
            assert float(s.partition().T_c_minus) == pytest.approx(t_ref, rel=1e-10)
