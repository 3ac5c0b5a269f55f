"""The compliant simulator on a terrain (``terrain=`` / a scenario's ``[terrain]``).

Independent references:

- rotation invariance: a rover on a uniform slope of angle alpha rising along +x, gravity
  (0, 0, -g), driving up into a face at beta from the horizontal, is exactly the rover on
  flat ground with gravity g (-sin alpha, 0, -cos alpha), driving along +x into a face at
  beta - alpha: the same system in a frame rotated by alpha about y (ground, face, gravity,
  start pose and velocity all rotate together; the mass matrix and the contact laws are
  invariant). So F_max, T_c^- and the contact duration agree. The flat run is also
  repeated on the flat-ground simulator (sphere wheels on the plane z = 0, the validated
  path), from the same start state: on flat ground an upright disc and a sphere touch
  alike.
- the same plane as a height field (Catmull-Rom reproduces planes exactly), as a Python
  function and as per-wheel planes: the plane's run.
- closed forms: a disc resting on a spherical bump settles with the contact normal along
  the line of centres and the normal force m g n_z (it is held where it stands, free to
  accelerate along the ground); a sled with locked wheels on a slope creeps at
  v_slip artanh(tan alpha / mu) with the ground forces balancing gravity (mu > tan alpha),
  or slides with a = g (sin alpha - mu cos alpha) (mu < tan alpha); a rocker-bogie settled
  with one wheel on a raised plane carries its weight on its wheels.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import roverimpact as ri
from roverimpact.cli import main
from roverimpact.exceptions import ConfigError, InputError
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.terrain import FunctionTerrain, HeightField, PlaneTerrain
from roverimpact.simulate import (
    SimulationConfig,
    build_system,
    initial_state,
    run,
    simulate_impact,
    simulate_scenario,
)
from tests.reference.sim_models import free_sphere

ALPHA = np.radians(10.0)
UP = np.array([-np.sin(ALPHA), 0.0, np.cos(ALPHA)])      # ground rising along +x
SLOPE = PlaneTerrain((0.0, 0.0, 0.0), UP)
HC = {"k": 1e7, "e": 0.5}
G = 9.81


def slope_h(x, y):
    """The slope as a height function (for [terrain] function)."""
    return np.tan(ALPHA) * np.asarray(x) + 0.0 * np.asarray(y)


def _models():
    return {"rover2d": (rover2d(suspension="rocker"), {"rocker": {"k": 50.0, "c": 2.0}}),
            "rocker_bogie": (rocker_bogie(), {})}


@pytest.fixture(scope="module")
def models():
    return _models()


@pytest.mark.parametrize("name,mu", [("rover2d", 0.0), ("rocker_bogie", 0.0),
                                     ("rover2d", 0.5)])
def test_uniform_slope_is_the_flat_run_with_gravity_rotated(models, monkeypatch, name, mu):
    mbm, springs = models[name]
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle=HC, springs=springs, mu=mu,
                           t_after=0.03)
    sloped = simulate_impact(mbm, cfg, terrain=SLOPE)
    monkeypatch.setattr(run, "gravity_vector",
                        lambda g: g * np.array([-np.sin(ALPHA), 0.0, -np.cos(ALPHA)]))
    flat_cfg = cfg.model_copy(update={"beta_deg": 60.0 - np.degrees(ALPHA)})
    flat = simulate_impact(mbm, flat_cfg, terrain=PlaneTerrain())
    # equivalent runs, different rounding: the adaptive steps differ at the integrator's
    # tolerance (rtol 1e-6), more so with friction (a stiffer run)
    rtol = 1e-6 if mu == 0.0 else 5e-6
    assert sloped.F_max_total == pytest.approx(flat.F_max_total, rel=rtol)
    assert sloped.T_c_minus == pytest.approx(flat.T_c_minus, rel=1e-6)
    assert sloped.v_n == pytest.approx(flat.v_n, rel=1e-6)
    assert sloped.contact_duration == pytest.approx(flat.contact_duration, rel=1e-5)
    assert sloped.A_rows == flat.A_rows
    # the flat terrain run on the flat-ground simulator (spheres on z = 0), same start
    q0, v0 = initial_state(mbm, flat_cfg, terrain=PlaneTerrain())
    legacy = simulate_impact(mbm, flat_cfg, q0=q0, v0=v0)
    assert legacy.F_max_total == pytest.approx(flat.F_max_total, rel=rtol)
    assert legacy.T_c_minus == pytest.approx(flat.T_c_minus, rel=1e-7)


def test_slope_start_is_a_translation_along_the_slope(models):
    mbm, springs = models["rover2d"]
    cfg = SimulationConfig(speed=0.3, springs=springs)
    q, v = initial_state(mbm, cfg, terrain=SLOPE)
    assert v[0] == pytest.approx(0.3 * np.cos(ALPHA), rel=1e-12)     # base x, z rates
    assert v[1] == pytest.approx(0.3 * np.sin(ALPHA), rel=1e-12)
    assert np.abs(v[2:4]).max() < 1e-12                                # pitch, rocker
    sys_ = build_system(mbm, cfg, terrain=SLOPE)
    cs = sys_.contacts(q, v)
    assert np.allclose(cs.n[0], UP, atol=1e-15)
    assert np.abs(cs.delta_dot[0]).max() < 1e-12                   # rolls along the slope
    assert np.abs(np.einsum("wkn,n->wk", cs.Jp[0], v)).max() < 1e-12   # without slip


def test_elastic_run_on_a_bumpy_height_field_conserves_energy():
    """e = 1 on ground and obstacle, no friction, undamped rocker spring: T + V (gravity,
    spring, k delta^(n+1)/(n+1) with delta = -gap) is constant through the impact over
    bumps, which holds only if the ground force n f_n at the rim point is -dV/dq, i.e.
    n^T J_p = d gap/dq (the envelope argument; exact on planes, up to a term of order
    delta x curvature on a curved terrain)."""
    x = np.arange(-3.0, 3.0 + 1e-9, 0.02)
    y = np.arange(-1.0, 1.0 + 1e-9, 0.02)
    z = (0.03 * np.exp(-((x[None, :] - 0.35) ** 2 + y[:, None] ** 2) / 0.01)
         + 0.02 * np.sin(2 * x[None, :]) * np.cos(3 * y[:, None]))
    bumps = HeightField(z, 0.02, (-3.0, -1.0))
    cfg = SimulationConfig(speed=0.3, obstacle={"name": "hertz", "k": 1e6, "e": 1.0},
                           ground_contact={"name": "hertz", "k": 1e6, "e": 1.0},
                           springs={"rocker": {"k": 40.0}}, t_after=0.05)
    r = simulate_impact(rover2d(suspension="rocker"), cfg, terrain=bumps)
    assert r.F_max_total > 0
    assert abs(r.E_plus - r.E_minus) < 1e-4 * r.T_minus


def test_plane_as_height_field_and_function_gives_the_plane_run(models):
    mbm, springs = models["rover2d"]
    cfg = SimulationConfig(speed=0.3, beta_deg=60.0, obstacle=HC, springs=springs,
                           t_after=0.03)
    x = np.arange(-2.0, 2.0 + 1e-9, 0.1)
    y = np.arange(-1.0, 1.0 + 1e-9, 0.1)
    hf = HeightField(slope_h(x[None, :], y[:, None]), 0.1, (-2.0, -1.0))
    fn = FunctionTerrain(slope_h, lambda x, y: (np.full_like(x, np.tan(ALPHA)),
                                                np.zeros_like(x)))
    want = simulate_impact(mbm, cfg, terrain=SLOPE)
    for terrain in (hf, fn):
        got = simulate_impact(mbm, cfg, terrain=terrain)
        assert got.F_max_total == pytest.approx(want.F_max_total, rel=1e-6)
        assert got.T_c_minus == pytest.approx(want.T_c_minus, rel=1e-6)


def test_per_wheel_planes_equal_to_the_plane_give_the_same_run():
    """[terrain.wheels.NAME] planes that are the slope itself (height of the slope under
    each wheel's centre in the configuration): the slope's run."""
    base = {"model": {"name": "rocker_bogie"}, "velocity": {"u": 0.3},
            "obstacle": {"wheel": "left_front", "beta_deg": 45.0},
            "contact_law": {"name": "hunt-crossley", **HC}, "simulation": {"t_after": 0.02}}
    sloped = ri.Scenario.model_validate({**base, "terrain": {"plane": {"normal": UP.tolist()}}})
    mbm = rocker_bogie()
    data = mbm.model.createData()
    pin.framesForwardKinematics(mbm.model, data, np.asarray(mbm.params["q_nominal"]))
    wheels = {}
    for w in mbm.wheels:
        c = data.oMf[mbm.model.getFrameId(w.frame)].translation
        wheels[w.name] = {"height": float(slope_h(c[0], c[1])), "normal": UP.tolist()}
    per_wheel = ri.Scenario.model_validate({**base, "terrain": {"wheels": wheels}})
    a, b = simulate_scenario(sloped), simulate_scenario(per_wheel)
    assert b.F_max_total == pytest.approx(a.F_max_total, rel=1e-7)
    assert b.T_c_minus == pytest.approx(a.T_c_minus, rel=1e-7)


def test_rover_with_a_wheel_on_a_raised_plane_settles_carrying_its_weight():
    """Flat per-wheel planes (left front 4 cm up): the settled rover is in equilibrium,
    every wheel loaded, the normal forces summing to the weight (all normals vertical)."""
    mbm = rocker_bogie()
    names = [w.name for w in mbm.wheels]
    raised = PlaneTerrain((0.0, 0.0, 0.04))
    terrain = {n: (raised if n == "left_front" else PlaneTerrain()) for n in names}
    cfg = SimulationConfig(speed=0.3)
    q, _ = initial_state(mbm, cfg, terrain=terrain)
    cs = build_system(mbm, cfg, terrain=terrain).contacts(q, np.zeros(mbm.model.nv))
    m = sum(i.mass for i in mbm.model.inertias)
    assert (cs.f_n[0] > 0.05 * m * G / 6).all()
    assert cs.f_n[0].sum() == pytest.approx(m * G, rel=1e-8)
    rocker = [j for j in ("rocker_left", "rocker_right") if mbm.model.existJointName(j)]
    assert rocker, "the rocker-bogie's rocker joints"
    iq = mbm.model.joints[mbm.model.getJointId(rocker[0])].idx_q
    assert abs(q[iq]) > 1e-3                 # the suspension took up the step


def test_disc_on_a_spherical_bump_settles_with_the_closed_form_normal():
    """A free disc (the test ball, axis y) placed on a spherical bump 0.12 m off its top,
    in the x-z plane through the bump's centre s. At rest, held where it stands and free
    to accelerate along the ground: contact normal = (c - s)/|c - s| (line of centres),
    normal force N = m g n_z, indentation R + r - |c - s| = (N/k)^(1/n). The bump is a
    height field (1 mm cells) of the sphere; its slopes are second-order accurate."""
    R, s = 0.5, np.array([0.0, 0.0, -0.4])
    k, dx, m, r = 1e10, 1e-3, 2.0, 0.1       # stiff ground: indentation 1.5 um
    x = np.arange(-0.25, 0.25 + 1e-9, dx)
    X, Y = np.meshgrid(x, x)
    bump = HeightField(s[2] + np.sqrt(R**2 - X**2 - Y**2), dx, (x[0], x[0]))
    mb = free_sphere(mass=m, radius=r)
    q0 = np.array(mb.params["q_nominal"])
    q0[:2] = 0.12, 0.0
    cfg = SimulationConfig(speed=0.1, ground_contact={"name": "hertz", "k": k, "e": 1.0})
    q, _ = initial_state(mb, cfg, q0=q0, terrain=bump)
    cs = build_system(mb, cfg, terrain=bump).contacts(q, np.zeros(6))
    c = q[:3]
    u = (c - s) / np.linalg.norm(c - s)
    assert c[0] == pytest.approx(0.12, abs=1e-4)                   # kept where it was
    assert np.abs(cs.n[0, 0] - u).max() < 5e-7
    N = m * G * u[2]
    assert cs.f_n[0, 0] == pytest.approx(N, rel=5e-7)
    assert R + r - np.linalg.norm(c - s) == pytest.approx((N / k) ** (1 / 1.5), rel=1e-4)


def _integrate(sys_, q0, t_end):
    """Free motion of a contact system from rest (the simulator's equations of motion)."""
    nv = sys_.nv

    def rhs(t, y):
        q = sys_.config(q0, y[:nv])
        _, tau = sys_.generalized_forces(q, y[nv:])
        return np.concatenate([sys_.chart_rate(q0, y[:nv], y[nv:]),
                               sys_.acceleration(q, y[nv:], tau)])

    sol = solve_ivp(rhs, (0.0, t_end), np.zeros(2 * nv), method="LSODA", rtol=1e-8,
                    atol=1e-10)
    return sys_.config(q0, sol.y[:nv, -1]), sol.y[nv:, -1]


@pytest.mark.parametrize("mu", [0.5, 0.1])
def test_sled_on_a_slope_with_friction(mu):
    """rover2d (rigid) with both wheels locked on the 10 deg slope, released at rest.
    mu = 0.5 > tan 10 deg: regularised Coulomb friction mu f_n tanh(v_t / v_slip) holds
    it at the creep speed v_slip artanh(tan alpha / mu), the ground forces balancing
    gravity (normal m g cos alpha, friction m g sin alpha). mu = 0.1 < tan 10 deg: it
    slides down with a = g (sin alpha - mu cos alpha)."""
    mbm = rover2d()
    cfg = SimulationConfig(speed=0.1, mu=mu, contacts={"locked": ["wheel_front",
                                                                  "wheel_rear"]})
    q0, _ = initial_state(mbm, cfg, terrain=SLOPE)
    sys_ = build_system(mbm, cfg, terrain=SLOPE, q_ref=q0)
    m = sum(i.mass for i in mbm.model.inertias)
    along = np.array([np.cos(ALPHA), 0.0, np.sin(ALPHA)])
    if mu > np.tan(ALPHA):
        q, v = _integrate(sys_, q0, 0.4)
        cs = sys_.contacts(q, v)
        assert cs.F[0].sum(axis=0) == pytest.approx([0.0, 0.0, m * G], abs=2e-3 * m * G)
        assert cs.f_n[0].sum() == pytest.approx(m * G * np.cos(ALPHA), rel=2e-3)
        assert cs.f_t[0].sum() == pytest.approx(m * G * np.sin(ALPHA), rel=5e-3)
        creep = cfg.v_slip * np.arctanh(np.tan(ALPHA) / mu)
        assert -(v[:2] @ along[[0, 2]]) == pytest.approx(creep, rel=2e-2)
    else:
        (_, v1), (_, v2) = _integrate(sys_, q0, 0.2), _integrate(sys_, q0, 0.3)
        a = -((v2 - v1)[:2] @ along[[0, 2]]) / 0.1
        assert a == pytest.approx(G * (np.sin(ALPHA) - mu * np.cos(ALPHA)), rel=1e-3)


def test_compiled_height_field_contact_is_wheel_ground_contact(rng):
    """The simulator's height-field contact (compiled) against the numpy
    wheel_ground_contact, random wheels (tilted axes) over a smooth field: the same
    algorithm, so the same gap to rounding; the rim angle of the minimum is found to
    about 1e-8 rad by both (the clearance is flat there), hence the point to ~1e-9 m."""
    from roverimpact.models.terrain import wheel_ground_contact
    from roverimpact.simulate.terrain import TerrainGround

    x = np.arange(-3.0, 3.0 + 1e-9, 0.05)
    y = np.arange(-2.0, 2.0 + 1e-9, 0.05)
    hf = HeightField(0.03 * np.sin(2 * x[None, :]) * np.cos(3 * y[:, None]), 0.05,
                     (-3.0, -2.0))
    n = 500
    C = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-1.5, 1.5, n), np.zeros(n)])
    C[:, 2] = hf.height(C[:, 0], C[:, 1]) + rng.uniform(0.1, 0.3, n)
    A = np.array([0.0, 1.0, 0.0]) + rng.normal(0.0, 0.1, (n, 3))
    A /= np.linalg.norm(A, axis=1)[:, None]
    r = rng.uniform(0.1, 0.3, n)
    want = wheel_ground_contact(hf, C, A, r)
    N, D, gap = TerrainGround(hf, [f"w{i}" for i in range(n)]).contact(C, A, r)
    assert np.abs(gap - want.gap).max() < 1e-12
    assert np.abs(N - want.normal).max() < 1e-8
    assert np.abs(C + D - want.point).max() < 1e-8
    # off a field built with outside='nan' a wheel has no ground
    nan_hf = HeightField(hf.z, 0.05, (-3.0, -2.0), outside="nan")
    C[0, :2] = 10.0, 10.0
    N, D, gap = TerrainGround(nan_hf, [f"w{i}" for i in range(n)]).contact(C, A, r)
    assert gap[0] == np.inf and np.isfinite(gap[1:]).all()


def test_face_of_finite_height_on_a_slope_is_measured_from_its_foot():
    """The face's foot is on the slope, ``distance`` d ahead of the front wheel along the
    face normal; the wheel (radius r) meets the face at the height, above the foot,
    r cos(alpha) - r cos(beta) - s sin(alpha), s = (r (1 - cos(beta - alpha)) + d) /
    sin(beta - alpha) the foot's distance along the slope from the wheel's ground contact.
    A face 3 mm higher is hit as an unbounded one; 3 mm lower, it is driven over."""
    from roverimpact.exceptions import SolverError

    rv = rover2d()
    r, d, b = rv.wheels[0].radius, 1e-3, np.radians(60.0)
    s = (r * (1 - np.cos(b - ALPHA)) + d) / np.sin(b - ALPHA)
    height = r * np.cos(ALPHA) - r * np.cos(b) - s * np.sin(ALPHA)
    base = dict(speed=0.3, beta_deg=60.0, distance=d, t_after=0.02, t_max=0.05)
    free = simulate_impact(rv, SimulationConfig(**base), terrain=SLOPE)
    high = simulate_impact(rv, SimulationConfig(**base, obstacle_height=height + 3e-3),
                           terrain=SLOPE)
    assert high.F_max_total == pytest.approx(free.F_max_total, rel=1e-9)
    with pytest.raises(SolverError, match="no obstacle contact"):
        simulate_impact(rv, SimulationConfig(**base, obstacle_height=height - 3e-3),
                        terrain=SLOPE)


# ---------------------------------------------------------------------- scenarios, studies
RV = {"model": {"name": "rover2d"}, "velocity": {"u": 0.3},
      "obstacle": {"wheel": "front", "beta_deg": 45.0},
      "contact_law": {"name": "hunt-crossley", **HC}, "simulation": {"t_after": 0.02}}


def test_simulated_study_case_on_a_function_terrain():
    from roverimpact.studies.evaluate import evaluate_case

    plane = simulate_scenario(ri.Scenario.model_validate(
        {**RV, "terrain": {"plane": {"normal": UP.tolist()}}}))
    out = evaluate_case({**RV, "terrain": {"function": "tests.test_simulate_terrain:slope_h"}},
                        simulate=True)
    assert out["sim_error"] == ""
    assert out["F_max"] == pytest.approx(plane.F_max_total, rel=1e-5)


# ---------------------------------------------------------------------- bad input
def test_wheel_driving_off_the_height_field_is_one_error(tmp_path, capsys):
    import tomli_w

    x = np.arange(-0.6, 0.8 + 1e-9, 0.05)
    np.save(tmp_path / "small.npy", np.zeros((5, x.size)))
    raw = {**RV, "terrain": {"file": "small.npy", "spacing": 0.05, "origin": [-0.6, -0.1]},
           "simulation": {"distance": 1.0, "t_max": 5.0}}
    path = tmp_path / "sc.toml"
    path.write_bytes(tomli_w.dumps(raw).encode())
    assert main(["simulate", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "wheel 'front'" in err and "no ground contact" in err and "Traceback" not in err


def test_bad_terrain_runs_are_refused():
    mbm = rover2d()
    with pytest.raises(ConfigError, match="ground = false with a terrain"):
        simulate_impact(mbm, {"ground": False}, terrain=SLOPE)
    steep = PlaneTerrain((0, 0, 0), (-np.sin(0.5), 0.0, np.cos(0.5)))    # 28.6 deg
    with pytest.raises(InputError, match="does not rise across the path"):
        simulate_impact(mbm, {"beta_deg": 20.0}, terrain=steep)
    hf = HeightField(np.zeros((3, 3)), 0.1, (5.0, 5.0))                # far from the rover
    with pytest.raises(ConfigError, match="outside the height field"):
        simulate_impact(mbm, {}, terrain=hf)


def test_compiled_contact_finds_the_deeper_basin_as_the_numpy_one():
    """On a random field where the clearance has two basins under some rims (the field of
    tests/test_terrain.py::test_lowest_rim_point_is_the_global_minimum), the compiled
    contact (wheel_ground_contact on a height field, and the simulator's TerrainGround)
    refines the same two scan minima as the numpy version: same gap; and its vertical
    clearance is the global minimum over the half rim found by a dense scan refined with
    scipy's bounded scalar minimiser."""
    from scipy.optimize import minimize_scalar

    from roverimpact.models.terrain import _numpy_contact, wheel_ground_contact, wheel_planes
    from roverimpact.models.terrain_synth import synthetic_mars
    from roverimpact.simulate.terrain import TerrainGround

    T = synthetic_mars((6.0, 6.0), 0.05, seed=1215, rms=0.08, corner_wavelength=3.0,
                       rock_abundance=1e-6, origin=(-3.0, -3.0))
    rng = np.random.default_rng(1)
    n, r = 2000, np.full(2000, 0.1)
    C = np.column_stack([rng.uniform(-2.5, 2.5, n), rng.uniform(-2.5, 2.5, n), np.zeros(n)])
    C[:, 2] = T.height(C[:, 0], C[:, 1]) + 0.1 + rng.uniform(-0.02, 0.02, n)
    yaw, tilt = rng.uniform(-np.pi, np.pi, n), rng.uniform(-0.3, 0.3, n)
    A = np.column_stack([-np.sin(yaw) * np.cos(tilt), np.cos(yaw) * np.cos(tilt), np.sin(tilt)])
    batch, _, c, _a, rr, e, f = wheel_planes(C, A, r)
    want = _numpy_contact(T, c, rr, e, f, 24, 12, batch)
    got = wheel_ground_contact(T, C, A, r)
    _, _, gap = TerrainGround(T, [f"w{i}" for i in range(n)]).contact(C, A, r)
    assert np.abs(got.gap - want.gap).max() < 1e-9
    assert np.abs(gap - want.gap).max() < 1e-9
    assert np.abs(got.point - want.point).max() < 1e-6
    assert np.abs(got.normal - want.normal).max() < 1e-6
    # the global minimum of the vertical clearance, by another method, on 60 wheels
    phis = np.linspace(-0.5 * np.pi, 0.5 * np.pi, 4001)
    for w in rng.choice(n, 60, replace=False):
        def g(phi, w=w):
            p = c[w] + rr[w] * (-np.cos(phi)[..., None] * e[w] + np.sin(phi)[..., None] * f[w])
            return p[..., 2] - T.height(p[..., 0], p[..., 1])
        k = int(np.argmin(g(phis)))
        lo, hi = phis[max(k - 1, 0)], phis[min(k + 1, phis.size - 1)]
        ref = minimize_scalar(g, bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-12}).fun
        assert got.gap[w] / got.normal[w, 2] == pytest.approx(min(ref, g(phis[k])), abs=1e-12)


def test_wheels_that_meet_the_face_together_are_reported_in_model_order():
    """Gaps equal to rounding (a symmetric rover's front wheels): the first wheel in the
    model's order, whichever is 1e-16 m nearer; a wheel nearer by more than ``TIE_GAP``
    wins; a wheel with no face ahead (inf, NaN) is never chosen."""
    from roverimpact.simulate.run import TIE_GAP, first_contact_wheel

    assert first_contact_wheel([0.3, 2e-16, 1e-16, np.inf]) == 1
    assert first_contact_wheel([1e-16, -1e-12, 0.2]) == 0
    assert first_contact_wheel([0.0, -2 * TIE_GAP, np.nan]) == 1
    assert first_contact_wheel([np.nan, np.inf, 0.5]) == 2
