"""The traverse pipeline against the scenario layer, and its speed limits against closed forms.

* Every (station, wheel) impact on rough synthetic terrain: T_c^-, m_eff, v_n and the rows
  held equal those of :meth:`roverimpact.scenario.ImpactSetup.from_state` (the one path
  every scenario takes) for the same state, with the supports declared as
  ``[[contacts.points]]`` (point and terrain normal) and the obstacle as ``normal``: the
  batched rows and the active-set call are the scenario's, item by item. This proves the
  pipeline, not the physics (that is tests/test_traverse_physics.py).
* A rover on level terrain before a step: the same T_c^- as the flat-ground scenario of
  ``rocker_bogie`` / ``rover2d`` with beta = arccos((r - h)/r) (docs/terrain.md), the
  existing, separately validated path.
* The driving velocity keeps every support and loop at zero rate, moves the base at u
  along its heading; the vectorised drive velocity equals ``scenario.build.velocity``.
* T_c^- scales with u^2 (and so the speed limits): recomputed at 2.5 u.
* Speed limits: for Hertz and Hunt-Crossley laws the peak force grows as
  v^(2n/(n+1)), so the bisection must give u (F_allow/F)^((n+1)/2n); for Kelvin-Voigt
  (linear) u F_allow/F.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import roverimpact as ri
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.terrain import FunctionTerrain
from roverimpact.models.terrain_synth import synthetic_mars
from roverimpact.scenario.build import velocity
from roverimpact.scenario.schema import (
    ContactLawSpec,
    ContactsSpec,
    ObstacleSpec,
    PointSpec,
    VelocitySpec,
)
from roverimpact.traverse.compute import (
    drive_velocity,
    evaluate_stations,
    rover_states,
)
from roverimpact.traverse.limits import peak_force, speed_limit_energy, speed_limit_force


@pytest.fixture(scope="module")
def rough():
    T = synthetic_mars((14.0, 6.0), 0.05, seed=4, rock_abundance=0.15, d_max=0.5,
                       origin=(0.0, -3.0))
    rb = rocker_bogie()
    x = np.arange(2.0, 12.0, 0.05)
    y = 0.3 * np.sin(x / 2.0)
    yaw = np.arctan(0.15 * np.cos(x / 2.0))
    return T, rb, x, y, yaw


@pytest.mark.filterwarnings("ignore::roverimpact.exceptions.HeldRowsWarning")  # noslip
@pytest.mark.parametrize("ground", ["normal", "noslip"])
def test_impacts_equal_scenario_from_state(rough, ground):
    T, rb, x, y, yaw = rough
    contacts = ContactsSpec(ground=ground)
    r = evaluate_stations(rb, T, x, y, yaw, u=0.2, max_travel=0.1, contacts=contacts)
    ok = np.asarray(r.pose.status) == "ok"
    assert ok.mean() > 0.97
    hits = np.argwhere((r.impact.T_c_minus > 0) & ok[:, None])
    assert len(hits) > 40
    rng = np.random.default_rng(1)
    names = list(r.wheels)
    model, data = rb.model, rb.model.createData()
    for k, w in hits[rng.choice(len(hits), 25, replace=False)]:
        q, v = r.pose.q[k], r.v[k]
        pin.framesForwardKinematics(model, data, q)
        pts = []
        for g, wh in enumerate(rb.wheels):
            if g == w:
                continue
            oMf = data.oMf[model.getFrameId(wh.frame)]
            local = oMf.actInv(r.pose.point[k, g])
            pts.append(PointSpec(frame=wh.frame, point=tuple(local), name=wh.name,
                                 normal=tuple(r.pose.normal[k, g]),
                                 tangential=ground == "noslip"))
        spec = ContactsSpec(ground_wheels=[], points=pts, ground=ground)
        setup = ri.ImpactSetup.from_state(
            rb, q, v, obstacle=ObstacleSpec(wheel=names[w], normal=tuple(r.hit["normal"][k, w])),
            contacts=spec)
        en = setup.partition()
        assert r.impact.T_c_minus[k, w] == pytest.approx(float(en.T_c_minus), rel=1e-8,
                                                         abs=1e-14)
        assert r.impact.v_n[k, w] == pytest.approx(float(en.v_n), rel=1e-9, abs=1e-14)
        assert r.impact.m_eff[k, w] == pytest.approx(float(en.m_eff), rel=1e-7)
        held = sorted(lab.replace("point:", "ground:") for lab in setup.labels
                      if not lab.startswith("obstacle"))
        mine = sorted(h for h in r.impact.held[k, w].split(";") if h)
        if ground == "noslip":   # the tangent rows span the same plane; compare the contacts
            held = sorted({h.rsplit(":", 1)[0] for h in held})
            mine = sorted({h.rsplit(":", 1)[0] for h in mine})
        assert mine == held
        # the driving velocity leaves the supports' normals and the loop at rest, so with
        # frictionless supports T_c^- = m v_n^2 / 2 (with no-slip rows, their scrubbing
        # velocity counts too)
        if ground == "normal":
            assert float(en.T_c_minus) == pytest.approx(
                0.5 * float(en.m_eff) * float(en.v_n) ** 2, rel=1e-7)


def test_driving_velocity(rough):
    T, rb, x, y, yaw = rough
    k = slice(0, 60)
    r = evaluate_stations(rb, T, x[k], y[k], yaw[k], u=0.3, max_travel=0.1)
    ok = np.asarray(r.pose.status) == "ok"
    q, v = r.pose.q[ok], r.v[ok]
    st = rover_states(rb, q)
    lever = r.pose.point[ok] - st.centre
    n = r.pose.normal[ok]
    rate = (np.einsum("kwj,kwjv,kv->kw", n, st.J[:, :, :3], v)
            + np.einsum("kwj,kwjv,kv->kw", np.cross(lever, n), st.J[:, :, 3:], v))
    assert np.abs(rate).max() < 1e-9
    assert np.abs(np.einsum("klv,kv->kl", st.loop_J, v)).max() < 1e-9
    for i in range(len(q)):            # the base moves horizontally at u along its heading
        R = pin.Quaternion(q[i, 3:7]).toRotationMatrix()
        lin = R @ v[i, :3]
        assert np.hypot(lin[0], lin[1]) == pytest.approx(0.3, rel=1e-9)
        assert np.arctan2(lin[1], lin[0]) == pytest.approx(yaw[k][ok][i], abs=1e-9)
    V = drive_velocity(rb, q, 0.3)
    for i in range(0, len(q), 7):
        assert V[i] == pytest.approx(velocity(rb, q[i], VelocitySpec(u=0.3)), abs=1e-13)


def test_speed_scaling(rough):
    T, rb, x, y, yaw = rough
    k = slice(40, 120)
    a = evaluate_stations(rb, T, x[k], y[k], yaw[k], u=0.1, max_travel=0.1)
    b = evaluate_stations(rb, T, x[k], y[k], yaw[k], u=0.25, max_travel=0.1)
    m = a.impact.T_c_minus > 0
    assert m.sum() > 10
    assert b.impact.T_c_minus[m] == pytest.approx(6.25 * a.impact.T_c_minus[m], rel=1e-7)
    assert b.impact.m_eff[m] == pytest.approx(a.impact.m_eff[m], rel=1e-7)
    # so the energy limit computed at either reference speed is the same
    T_allow = 0.01
    assert speed_limit_energy(b.impact.T_c_minus[m], 0.25, T_allow) == pytest.approx(
        speed_limit_energy(a.impact.T_c_minus[m], 0.1, T_allow), rel=1e-7)


def _step(h, x_e, side=None):
    def f(x, y):
        up = x >= x_e
        if side is not None:
            up = up & (np.sign(y) == side)
        return np.where(up, h, 0.0) + 0.0 * y
    return FunctionTerrain(f)


@pytest.mark.parametrize("h", [0.02, 0.05, 0.08])
def test_flat_ground_step_equals_scenario(h):
    """The rocker-bogie on level ground, a step of height h across the path of its left
    wheels only: the left front wheel meets the edge at beta = arccos((r - h)/r), and its
    T_c^- equals the flat-ground scenario's at that beta (ground rows of the other wheels,
    the differential, automatic active set)."""
    rb = rocker_bogie()
    r_w = rb.wheels[0].radius
    xs = np.array([0.0])
    # the left front wheel (x = 0.3 from the base) 2 cm before touching the edge
    x_e = 0.3 + np.sqrt(2 * r_w * h - h * h) + 0.02
    res = evaluate_stations(rb, _step(h, x_e, side=1), xs, 0 * xs, 0 * xs, u=0.4,
                            max_travel=0.05)
    names = list(res.wheels)
    w = names.index("left_front")
    assert res.hit["found"][0].tolist() == [n == "left_front" for n in names]
    beta = np.arccos((r_w - h) / r_w)
    assert res.hit["beta"][0, w] == pytest.approx(beta, abs=1e-7)
    assert res.hit["distance"][0, w] == pytest.approx(0.02, abs=1e-7)
    sc = ri.Scenario.model_validate({"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.4},
                                     "obstacle": {"wheel": "left_front",
                                                  "beta_deg": float(np.degrees(beta))}})
    en = ri.ImpactSetup.from_scenario(sc).partition()
    assert res.impact.T_c_minus[0, w] == pytest.approx(float(en.T_c_minus), rel=1e-9)
    assert res.impact.m_eff[0, w] == pytest.approx(float(en.m_eff), rel=1e-9)
    assert res.impact.v_n[0, w] == pytest.approx(float(en.v_n), rel=1e-9)


def test_planar_rover_step_equals_scenario():
    rv = rover2d(suspension="rocker")
    r_w = rv.wheels[0].radius
    h = 0.04
    q0 = np.array(rv.params["q_nominal"])
    data = rv.model.createData()
    pin.framesForwardKinematics(rv.model, data, q0)
    xf = data.oMf[rv.model.getFrameId(rv.wheels[0].frame)].translation[0]
    assert rv.wheels[0].name == "front"
    x_e = xf + np.sqrt(2 * r_w * h - h * h) + 0.01
    res = evaluate_stations(rv, _step(h, x_e), [0.0], [0.0], [0.0], u=0.3, max_travel=0.05)
    beta = np.arccos((r_w - h) / r_w)
    assert res.hit["beta"][0, 0] == pytest.approx(beta, abs=1e-7)
    sc = ri.Scenario.model_validate({"model": {"name": "rover2d",
                                               "params": {"suspension": "rocker"}},
                                     "velocity": {"u": 0.3},
                                     "obstacle": {"wheel": "front",
                                                  "beta_deg": float(np.degrees(beta))}})
    en = ri.ImpactSetup.from_scenario(sc).partition()
    assert res.impact.T_c_minus[0, 0] == pytest.approx(float(en.T_c_minus), rel=1e-9)


@pytest.mark.parametrize("law", [{"name": "hunt-crossley", "k": 1e7, "e": 0.5},
                                 {"name": "hertz", "k": 3e6},
                                 {"name": "flores", "k": 1e6, "e": 0.3, "n": 1.2},
                                 {"name": "kelvin-voigt", "k": 1e6, "e": 0.6},
                                 {"name": "kelvin-voigt", "k": 1e6, "c": 300.0}])
def test_force_speed_limit_closed_form(law):
    spec = ContactLawSpec(**law)
    rng = np.random.default_rng(0)
    m = rng.uniform(1.0, 30.0, 40)
    vn = rng.uniform(0.01, 0.5, 40)
    u = 0.2
    F = peak_force(spec, m, vn)
    F_allow = 400.0
    v = speed_limit_force(spec, m, vn, u, F_allow)
    if spec.name == "kelvin-voigt":
        expect = u * F_allow / F                       # F linear in v (linear ODE)
    else:
        n = spec.to_law().n
        expect = u * (F_allow / F) ** ((n + 1) / (2 * n))
    assert v == pytest.approx(expect, rel=1e-9)
    # and the peak force at the limit is the allowable one
    assert peak_force(spec, m, vn * v / u) == pytest.approx(F_allow, rel=1e-9)
    # no impact: no limit; a rigid lock: stop
    out = speed_limit_force(spec, [np.nan, 2.0, np.inf], [np.nan, -0.1, 0.2], u, F_allow)
    assert np.isnan(out[0]) and out[1] == np.inf and out[2] == 0.0


def test_energy_speed_limit():
    assert speed_limit_energy([0.04, 0.0, np.nan], 0.1, 0.01).tolist()[:2] == \
        pytest.approx([0.05, np.inf])


def test_file_model_step_equals_scenario():
    """A robot file as a scenario declares it (examples/mjcf_rover.xml, a planar MJCF rover
    with its wheels declared): on level ground before a step, T_c^- of the front wheel
    equals the flat-ground scenario of the same [model] table."""
    from pathlib import Path

    from roverimpact.scenario.build import make_model
    from roverimpact.scenario.schema import ModelSpec

    table = {"file": str(Path(__file__).resolve().parents[1] / "examples" / "mjcf_rover.xml"),
             "wheels": {"front": {"frame": "front_wheel"}, "rear": {"frame": "rear_wheel"}}}
    mbm = make_model(ModelSpec.model_validate(table))
    names = [w.name for w in mbm.wheels]
    front = names.index("front")
    r_w = mbm.wheels[front].radius
    data = mbm.model.createData()
    q0 = np.array(mbm.params["q_nominal"])
    pin.framesForwardKinematics(mbm.model, data, q0)
    xf = data.oMf[mbm.model.getFrameId(mbm.wheels[front].frame)].translation[0]
    h = 0.05
    x_e = xf + np.sqrt(2 * r_w * h - h * h) + 0.01
    res = evaluate_stations(mbm, _step(h, x_e), [q0[0]], [0.0], [0.0], u=0.5,
                            max_travel=0.05)
    beta = np.arccos((r_w - h) / r_w)
    assert res.hit["beta"][0, front] == pytest.approx(beta, abs=1e-7)
    sc = ri.Scenario.model_validate({"model": table, "velocity": {"u": 0.5},
                                     "obstacle": {"wheel": "front",
                                                  "beta_deg": float(np.degrees(beta))}})
    en = ri.ImpactSetup.from_scenario(sc).partition()
    assert res.impact.T_c_minus[0, front] == pytest.approx(float(en.T_c_minus), rel=1e-9)


def test_reference_speed_is_a_map_speed_on_a_slope():
    """On a 10 deg slope the traverse drives the base at u horizontally (a map speed:
    u / cos 10 deg along the ground), a scenario's [velocity] u on the same [terrain] at u
    along the ground, so T_c^- differs by 1 / cos^2 10 deg (docs/traverse.md)."""
    alpha = np.radians(10.0)
    rb = rocker_bogie()
    T = FunctionTerrain(lambda x, y: np.tan(alpha) * x + 0.0 * y)
    r = evaluate_stations(rb, T, np.array([1.0]), np.array([0.0]), np.array([0.0]), u=0.2,
                          max_travel=0.05)
    q, v = r.pose.q[0], r.v[0]
    lin = pin.Quaternion(q[3:7]).toRotationMatrix() @ v[:3]
    assert lin[0] == pytest.approx(0.2, rel=1e-9)
    assert np.linalg.norm(lin) == pytest.approx(0.2 / np.cos(alpha), rel=1e-6)
    n = [-np.sin(alpha), 0.0, np.cos(alpha)]
    sc = ri.Scenario.model_validate({
        "model": {"name": "rocker_bogie"}, "velocity": {"u": 0.2},
        "configuration": {"base": {"x": 1.0, "y": 0.0}},
        "obstacle": {"wheel": "left_front", "beta_deg": 45.0},
        "terrain": {"plane": {"point": [0.0, 0.0, 0.0], "normal": n}}})
    s = ri.ImpactSetup.from_scenario(sc)
    lin_sc = pin.Quaternion(s.q[3:7]).toRotationMatrix() @ s.v[:3]
    assert np.linalg.norm(lin_sc) == pytest.approx(0.2, rel=1e-6)


def test_contact_duration_is_the_closed_form():
    """traverse.limits.contact_duration (the window check of the weight model): Hertz's
    duration 2.9432 delta_max / v (Johnson, Contact Mechanics, eq. 11.24 with the 1-DoF
    delta_max), NaN without an impact or for a rigid lock."""
    from roverimpact.traverse.limits import contact_duration

    spec = ContactLawSpec(name="hertz", k=1e6)
    m, v = np.array([10.0, 2.0, 10.0, np.inf]), np.array([0.5, 0.1, 0.0, 0.5])
    d = contact_duration(spec, m, v)
    dmax = (2.5 * m[:2] * v[:2] ** 2 / (2 * 1e6)) ** 0.4
    np.testing.assert_allclose(d[:2], 2.9432 * dmax / v[:2], rtol=1e-4)
    assert np.isnan(d[2:]).all()


def test_rigid_planar_rover_before_a_ramp_against_hand_and_scipy(tmp_path):
    """The whole chain for the rigid ``rover2d`` (24 kg, wheels 0.15 m at x = +-0.3 m, COM
    at mid-wheelbase, h = 0.35 m) on level ground before a 30 degree ramp, against a
    derivation of its own: a planar rigid body (x, z, pitch; the wheel spins drop out, every
    normal passes through a wheel centre) with M = diag(m, m, I_G).

    * the feature row n^T (v_G + omega x p) at the front wheel centre, n = (-sin 30,
      cos 30): m_eff = 1 / (a M^-1 a^T), v_n = u sin 30, T_c^- = 1/2 m_eff v_n^2 (the rear
      support releases: its impulse with both rows held is negative);
    * Hertz: F = k^(2/5) (5/4 m_eff v_n^2)^(3/5), u_lim = u (F_allow / F)^(5/6);
    * the weight model: the same body on two preloaded Hunt-Crossley supports
      (k = 1e7, z = 3(1 - e)/2 with e = 0.2, v_i = 0.1 m/s, m g / 2 each) meeting the ramp's
      plane (Hertz), integrated by scipy's LSODA: the peak within 0.05 s at u, and
      F_allow at the reported limit.
    """
    from scipy.integrate import solve_ivp

    from roverimpact.traverse.run import run_traverse

    dx, gamma = 0.005, np.radians(30.0)
    x = -1.0 + dx * np.arange(801)
    z = np.tile(np.clip((x - 1.0) * np.tan(gamma), 0.0, 0.05), (401, 1))
    np.save(tmp_path / "ramp.npy", z)
    u, F_allow, k = 0.1, 150.0, 1.0e7
    cfg = {"terrain": {"kind": "file", "file": str(tmp_path / "ramp.npy"), "spacing": dx,
                       "origin": [-1.0, -1.0]},
           "path": {"name": "p", "waypoints": [[0.62, 0.0], [0.63, 0.0]], "spacing": 0.02},
           "model": {"name": "rover2d"},
           "drive": {"speed": u, "v_max": 1.0, "look_ahead": 0.1},
           "limits": {"F_allow": F_allow}, "contact_law": {"name": "hertz", "k": k}}
    W = run_traverse(cfg).wheels
    hit = W[W["T_c_minus"] > 0]
    assert len(hit) == 1 and hit["wheel"].iloc[0] == "front"
    r = hit.iloc[0]
    assert r["beta_deg"] == pytest.approx(30.0, abs=1e-4)

    m_c, m_w, rw, h, g = 19.0, 2.5, 0.15, 0.35, 9.81
    m = m_c + 2 * m_w
    z_c = (m * h - 2 * m_w * rw) / m_c
    I_G = (m_c * (0.7**2 + 0.15**2) / 12 + m_c * (z_c - h) ** 2
           + 2 * m_w * (0.3**2 + (rw - h) ** 2))
    Minv = np.diag([1 / m, 1 / m, 1 / I_G])

    def row(p, n):            # n . velocity of the point p (from G): (xd + thd pz, zd - thd px)
        return np.array([n[0], n[1], n[0] * p[1] - n[1] * p[0]])

    nf = (-np.sin(gamma), np.cos(gamma))
    a = row((0.3, rw - h), nf)
    rows = np.array([row((-0.3, -h), (0, 1)), row((0.3, -h), (0, 1)), a])
    m_eff = 1.0 / (a @ Minv @ a)
    v_n = u * np.sin(gamma)
    G2 = rows[[0, 2]] @ Minv @ rows[[0, 2]].T        # rear + feature, both held
    assert np.linalg.solve(G2, [0.0, v_n])[0] < 0    # the rear would pull: it releases
    assert r["m_eff"] == pytest.approx(m_eff, rel=1e-6)
    assert r["v_n"] == pytest.approx(v_n, rel=1e-6)
    assert r["T_c_minus"] == pytest.approx(0.5 * m_eff * v_n**2, rel=1e-6)
    F = k**0.4 * (1.25 * m_eff * v_n**2) ** 0.6
    assert r["F_pred"] == pytest.approx(F, rel=1e-6)
    assert r["v_lim_closed"] == pytest.approx(u * (F_allow / F) ** (5 / 6), rel=1e-6)

    zeta, d0 = 1.5 * (1 - 0.2), (m * g / 2 / k) ** (2 / 3)

    def peak(speed):
        def rhs(t, y):
            d, rate = y[3:], -rows @ y[:3]
            f = np.zeros(3)
            f[:2] = np.where(d[:2] > 0, k * np.clip(d[:2], 0, None) ** 1.5
                             * (1 + zeta * rate[:2] / 0.1), 0.0).clip(min=0.0)
            f[2] = k * max(d[2], 0.0) ** 1.5
            return np.r_[Minv @ (rows.T @ f + [0.0, -m * g, 0.0]), rate]
        sol = solve_ivp(rhs, (0.0, 0.05), [speed, 0, 0, d0, d0, 0.0], method="LSODA",
                        rtol=1e-10, atol=1e-13, max_step=2e-5, dense_output=True)
        d = sol.sol(np.linspace(0.0, 0.05, 20001))[5]
        return k * np.clip(d, 0, None).max() ** 1.5

    assert r["F_model"] == pytest.approx(peak(u), rel=2e-4)          # 163.3 N
    assert peak(r["v_lim"]) == pytest.approx(F_allow, rel=3e-3)      # at 0.0907 m/s


def test_robot_files_steering_locked_as_in_a_scenario():
    """The Sawppy-like URDF of examples/sawppy_like_beta.toml holds its four steering
    joints with contacts.locked, as its scenario does. The traverse refused them
    ("contacts.locked: 'steer_left_front' is not a suspension joint of 'sawppy_like'
    ([])": a plain URDF declares no suspension joints) and its pose solver took them for
    pose unknowns. Now any 1-DoF joint is locked as in a scenario: on level ground before a
    step across the left wheels' path, the left front wheel's T_c^-, m_eff and v_n equal
    the scenario's at beta = arccos((r - h)/r) with the same locked rows."""
    from pathlib import Path

    import tomllib

    from roverimpact.scenario.build import make_model
    from roverimpact.scenario.schema import ContactsSpec, LoopSpec, ModelSpec

    ex = Path(__file__).resolve().parents[1] / "examples"
    raw = tomllib.loads((ex / "sawppy_like_beta.toml").read_text())
    raw["model"]["file"] = str(ex / raw["model"]["file"])
    loops = [LoopSpec.model_validate(lp) for lp in raw["contacts"]["loops"]]
    mbm = make_model(ModelSpec.model_validate(raw["model"]), loops=loops)
    contacts = ContactsSpec(locked=raw["contacts"]["locked"])
    names = [w.name for w in mbm.wheels]
    w = names.index("left_front")
    r_w, h = mbm.wheels[w].radius, 0.02
    data = mbm.model.createData()
    q0 = np.array(mbm.params.get("q_nominal", pin.neutral(mbm.model)))
    pin.framesForwardKinematics(mbm.model, data, q0)
    xf, yf = data.oMf[mbm.model.getFrameId(mbm.wheels[w].frame)].translation[:2]
    x_e = xf + np.sqrt(2 * r_w * h - h * h) + 0.01
    terrain = FunctionTerrain(lambda x, y: np.where((x >= x_e) & (y * np.sign(yf) > 0.05),
                                                    h, 0.0))
    res = evaluate_stations(mbm, terrain, [0.0], [0.0], [0.0], u=0.3, max_travel=0.05,
                            contacts=contacts)
    assert res.pose.status[0] == "ok"
    assert res.hit["found"][0].tolist() == [n == "left_front" for n in names]
    beta = np.arccos((r_w - h) / r_w)
    assert res.hit["beta"][0, w] == pytest.approx(beta, abs=1e-7)
    sc = dict(raw, obstacle={"wheel": "left_front", "beta_deg": float(np.degrees(beta))})
    sc.pop("simulation")
    en = ri.ImpactSetup.from_scenario(ri.Scenario.model_validate(sc)).partition()
    assert res.impact.T_c_minus[0, w] == pytest.approx(float(en.T_c_minus), rel=1e-8)
    assert res.impact.m_eff[0, w] == pytest.approx(float(en.m_eff), rel=1e-8)
    assert res.impact.v_n[0, w] == pytest.approx(float(en.v_n), rel=1e-8)
    assert all(f"lock:{j}" in res.impact.held[0, w] for j in contacts.locked)


@pytest.mark.parametrize("h, impact", [(5e-10, False), (2e-9, True)])
def test_a_bump_lower_than_the_pose_tolerance_is_touching_not_an_impact(h, impact):
    """A plain URDF rover posed on a height field of a plane with rounding-level noise got
    "impacts" of about 1e-11 J: terrain points a fraction of a nanometre above the wheel's
    rolling line, met at a rim angle of 1e-4 rad. A wheel of radius r rolling at u onto a
    bump of height h meets it at v_n = u sin(theta), r (1 - cos(theta)) = h (closed form);
    below the pose solver's own tolerance (POSE_TOL = 1e-9 m on every gap) the bump cannot
    be told from the support: v_n at or below touch_speeds = u sqrt(2 POSE_TOL / r) is
    touching, no impact (T_c^- = 0, no m_eff, v_n kept). The 2-D rover's front wheel
    before a step of h; above the tolerance the impact is kept, T_c^- = m_eff v_n^2 / 2."""
    from roverimpact.traverse.compute import POSE_TOL, touch_speeds

    rv = rover2d(suspension="rocker")
    r_w, u = rv.wheels[0].radius, 0.3
    q0 = np.array(rv.params["q_nominal"])
    data = rv.model.createData()
    pin.framesForwardKinematics(rv.model, data, q0)
    xf = data.oMf[rv.model.getFrameId(rv.wheels[0].frame)].translation[0]
    x_e = xf + np.sqrt(2 * r_w * h - h * h) + 0.01
    res = evaluate_stations(rv, _step(h, x_e), [0.0], [0.0], [0.0], u=u, max_travel=0.05)
    assert res.hit["found"][0].tolist() == [True, False]
    v_n = u * np.sin(np.arccos((r_w - h) / r_w))
    assert res.impact.v_n[0, 0] == pytest.approx(v_n, rel=1e-6)
    assert (v_n > touch_speeds(r_w, u)) == impact == (h > POSE_TOL)
    T = res.impact.T_c_minus[0, 0]
    if impact:
        assert T == pytest.approx(0.5 * res.impact.m_eff[0, 0] * v_n ** 2, rel=1e-6)
    else:
        assert T == 0.0 and np.isnan(res.impact.m_eff[0, 0]) and res.impact.held[0, 0] == ""
