"""Pose on terrain: base pose and suspension so that the chosen wheels touch, loops closed.

References (independent of the code under test):
* flat ground: the builders' own nominal pose ``params["q_nominal"]`` (wheels at z = r);
* a tilted plane: closed forms. A rigid rover's wheel centres lie in a plane parallel to
  its base's x-y plane at the nominal height, so on the plane n . (p - p0) = 0 its base
  axis z equals n and its base origin lies at the nominal height along n;
* contact: a brute-force scan of the rim (20 001 angles) against the terrain's height,
  from Pinocchio's forward kinematics, not ``wheel_ground_contact``;
* the Jacobian: central finite differences of the residual in the solver's coordinates
  and along every tangent direction (``pin.integrate``);
* the nearest pose of an underdetermined problem: scipy's SLSQP minimising the distance
  to the guess subject to the same contact equations;
* the simulator's settling (``initial_state``) from the pose.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize

from roverimpact.exceptions import InputError, ModelError, SolverError
from roverimpact.models import (
    export_urdf,
    joint_slices,
    load_robot,
    rigid_body,
    rocker_bogie,
    rover2d,
)
from roverimpact.models.constraints import point_jacobian
from roverimpact.models.pose import PoseError, PoseProblem, place, pose_on_terrain
from roverimpact.models.terrain import FunctionTerrain, HeightField, PlaneTerrain
from roverimpact.models.terrain_synth import synthetic_mars

SETTINGS = settings(max_examples=20, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
SUSPENSIONS = [dict(suspension=s, middle_wheel=m) for s in ("rigid", "rocker", "prismatic")
               for m in (False, True)]
PRESETS = ("prototype", "mer", "sojourner")


@pytest.fixture(scope="module")
def mars():
    """A 12 m x 12 m synthetic Mars terrain centred on the origin (rocks up to 0.4 m)."""
    return synthetic_mars((12.0, 12.0), 0.05, seed=3, rock_abundance=0.05, d_max=0.4,
                          origin=(-6.0, -6.0))


def _waves():
    """A smooth terrain with its exact gradient (a FunctionTerrain)."""
    def f(x, y):
        return 0.04 * np.sin(2.0 * x) * np.cos(1.5 * y) + 0.05 * x - 0.02 * y

    def grad(x, y):
        return (0.08 * np.cos(2.0 * x) * np.cos(1.5 * y) + 0.05,
                -0.06 * np.sin(2.0 * x) * np.sin(1.5 * y) - 0.02)
    return FunctionTerrain(f, grad)


def _rim_clearance(mbm, terrain, q, n=20001):
    """Vertical clearance min over the rim of p_z - h(p_x, p_y) for each wheel (brute force).

    Rim: c + r(cos t u + sin t w) with (u, w) an orthonormal basis of the wheel plane, all
    of it (not only the lower half).
    """
    model = mbm.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    t = np.linspace(-np.pi, np.pi, n)
    out = []
    for w in mbm.wheels:
        M = data.oMf[model.getFrameId(w.frame)]
        a = M.rotation @ np.asarray(w.axis, float)
        u = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(a, u)
        p = M.translation + w.radius * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v)
        out.append(np.min(p[:, 2] - terrain.height(p[:, 0], p[:, 1])))
    return np.array(out)


# ------------------------------------------------------------------ flat and tilted ground
@pytest.mark.parametrize("kw", SUSPENSIONS)
def test_flat_ground_gives_the_nominal_pose_rover2d(kw):
    """Every suspension of rover2d: from a guess 5 cm high and pitched, the nominal pose.

    With the suspension fixed the problem is square (or overdetermined and consistent);
    with it free, the perturbation is taken in the row space of the equations so that
    the nearest pose is the nominal one.
    """
    rv = rover2d(**kw)
    qn = np.array(rv.params["q_nominal"])
    guess = qn.copy()
    guess[1] += 0.05
    guess[2] += 0.1
    pose = pose_on_terrain(rv, PlaneTerrain(), guess, fixed=rv.lockable_joints)
    np.testing.assert_allclose(pose.q, qn, atol=1e-9)
    assert pose.solved == ("base_z", "base_pitch")
    prob = PoseProblem(rv, PlaneTerrain())
    _, J, _ = prob.evaluate(qn)
    _, s, Vt = np.linalg.svd(J)
    row = Vt[: int(np.sum(s > 1e-9))].T @ np.linspace(0.02, 0.05, int(np.sum(s > 1e-9)))
    pose = pose_on_terrain(rv, PlaneTerrain(), prob.step(qn, row))
    np.testing.assert_allclose(pose.q, qn, atol=1e-9)
    np.testing.assert_allclose(pose.gap, 0.0, atol=1e-9)


@pytest.mark.parametrize("preset", PRESETS)
def test_flat_ground_gives_the_nominal_pose_rocker_bogie(preset):
    rb = rocker_bogie(preset)
    qn = np.array(rb.params["q_nominal"])
    s = joint_slices(rb.model)
    guess = place(rb, 0.3, -0.2, yaw=0.7)
    guess[2] += 0.04
    guess[s["rocker_left"][0]] = 0.1        # loop open, bogies tilted
    guess[s["bogie_right"][0]] = -0.2
    pose = pose_on_terrain(rb, PlaneTerrain(), guess)
    np.testing.assert_allclose(pose.q, place(rb, 0.3, -0.2, yaw=0.7), atol=1e-9)
    np.testing.assert_allclose(pose.q[:7] - place(rb, 0.3, -0.2, yaw=0.7)[:7], 0, atol=1e-9)
    assert abs(pose.q[2] - qn[2]) < 1e-9
    assert np.abs(pose.loop_residual).max() < 1e-12
    assert pose.rank == len(pose.solved) == 7


def _plane(normal, point=(0.2, -0.1, 0.3)):
    n = np.asarray(normal, float)
    return PlaneTerrain(point, n), n / np.linalg.norm(n), np.asarray(point, float)


normals = st.tuples(st.floats(-0.4, 0.4), st.floats(-0.4, 0.4)).map(
    lambda g: (-g[0], -g[1], 1.0))       # planes of slope up to about 30 degrees


@SETTINGS
@given(normal=normals, yaw=st.floats(-np.pi, np.pi), xy=st.tuples(st.floats(-1, 1),
                                                                   st.floats(-1, 1)),
       preset=st.sampled_from(PRESETS), rigid=st.booleans())
def test_tilted_plane_rocker_bogie_takes_the_slope(normal, yaw, xy, preset, rigid):
    """Base z axis = plane normal with the yaw held: n' = R_z(-yaw) n =
    (cos(roll) sin(pitch), -sin(roll), cos(roll) cos(pitch)); base height z_nom along n."""
    rb = rocker_bogie(preset)
    terrain, n, p0 = _plane(normal)
    guess = place(rb, *xy, yaw=yaw)
    pose = pose_on_terrain(rb, terrain, guess, fixed=rb.lockable_joints if rigid else ())
    c, s_ = np.cos(-yaw), np.sin(-yaw)
    nl = np.array([c * n[0] - s_ * n[1], s_ * n[0] + c * n[1], n[2]])
    roll, pitch = -np.arcsin(nl[1]), np.arctan2(nl[0], nl[2])
    z_nom = rb.params["q_nominal"][2]
    z = p0[2] + (z_nom - n[0] * (xy[0] - p0[0]) - n[1] * (xy[1] - p0[1])) / n[2]
    R = pin.Quaternion(pose.q[3:7]).toRotationMatrix()
    np.testing.assert_allclose(pin.rpy.matrixToRpy(R), [roll, pitch, yaw], atol=1e-8)
    np.testing.assert_allclose(pose.q[:3], [xy[0], xy[1], z], atol=1e-9)
    np.testing.assert_allclose(pose.q[7:], np.array(rb.params["q_nominal"])[7:], atol=1e-8)


@pytest.mark.parametrize("slope_deg", [-20.0, -5.0, 3.0, 15.0])
def test_tilted_plane_rover2d_takes_the_slope(slope_deg):
    """Ground rising forward by alpha: pitch = -alpha (+ is nose down) and the chassis COM
    at z_c along the normal: z = (z_c + x sin(alpha)) / cos(alpha)."""
    a = np.deg2rad(slope_deg)
    terrain = PlaneTerrain((0, 0, 0), (-np.sin(a), 0.0, np.cos(a)))
    for kw in (dict(suspension="rigid"), dict(suspension="rocker", middle_wheel=True),
               dict(suspension="prismatic")):
        rv = rover2d(**kw)
        x = 0.4
        pose = pose_on_terrain(rv, terrain, place(rv, x), fixed=rv.lockable_joints)
        z_c = rv.params["chassis_com_height"]
        np.testing.assert_allclose(pose.q[:3], [x, (z_c + x * np.sin(a)) / np.cos(a), -a],
                                   atol=1e-9)


# ------------------------------------------------------------------ random terrain
@pytest.mark.parametrize("preset", PRESETS)
def test_rocker_bogie_on_random_terrain(preset, mars):
    """Many random (x, y, yaw): every wheel within 1e-6 m of the terrain (brute-force rim
    scan), none below it, the differential closed to 1e-9, x, y, yaw and spins kept."""
    rb = rocker_bogie(preset)
    rng = np.random.default_rng(11)
    Q = np.array([place(rb, *rng.uniform(-4.5, 4.5, 2), yaw=rng.uniform(-np.pi, np.pi))
                  for _ in range(40)])
    pose = pose_on_terrain(rb, mars, Q)
    assert pose.q.shape == Q.shape and pose.gap.shape == (40, 6)
    assert np.abs(pose.loop_residual).max() < 1e-9
    assert np.abs(pose.gap).max() < 1e-9
    np.testing.assert_allclose(pose.q[:, :2], Q[:, :2], atol=0)
    spins = [joint_slices(rb.model)[f"wheel_{w.name}"][0].start for w in rb.wheels]
    np.testing.assert_array_equal(pose.q[:, spins], Q[:, spins])
    for i in range(0, 40, 4):
        R = pin.Quaternion(pose.q[i, 3:7]).toRotationMatrix()
        R0 = pin.Quaternion(Q[i, 3:7]).toRotationMatrix()
        assert abs(pin.rpy.matrixToRpy(R)[2] - pin.rpy.matrixToRpy(R0)[2]) < 1e-12
        g = _rim_clearance(rb, mars, pose.q[i])
        assert np.abs(g).max() < 1e-6, g


@SETTINGS
@given(seed=st.integers(0, 10_000), x=st.floats(-2.0, 2.0), y=st.floats(-2.0, 2.0),
       yaw=st.floats(-np.pi, np.pi))
def test_rocker_bogie_on_any_smooth_random_field(seed, x, y, yaw):
    """A random smooth height field (seeded fractal surface, no rocks, 8 cm rms)."""
    terrain = synthetic_mars((6.0, 6.0), 0.05, seed=seed, rms=0.08, corner_wavelength=3.0,
                             rock_abundance=1e-6, origin=(-3.0, -3.0))
    rb = rocker_bogie()
    pose = pose_on_terrain(rb, terrain, place(rb, x, y, yaw))
    assert np.abs(_rim_clearance(rb, terrain, pose.q)).max() < 1e-6
    assert np.abs(pose.loop_residual).max() < 1e-9


@pytest.mark.parametrize("kw", [dict(suspension="rigid"), dict(suspension="rocker"),
                                dict(suspension="prismatic"),
                                dict(suspension="prismatic", middle_wheel=True)])
def test_rover2d_on_random_terrain(kw, mars):
    rv = rover2d(**kw)
    Q = np.array([place(rv, x) for x in np.linspace(-4.0, 4.0, 25)])
    pose = pose_on_terrain(rv, mars, Q)
    for i in range(0, 25, 6):
        assert np.abs(_rim_clearance(rv, mars, pose.q[i])).max() < 1e-6


def test_batch_equals_one_by_one(mars):
    rb = rocker_bogie()
    rng = np.random.default_rng(2)
    Q = np.array([place(rb, *rng.uniform(-3, 3, 2), yaw=rng.uniform(-3, 3)) for _ in range(5)])
    batch = pose_on_terrain(rb, mars, Q.reshape(5, 1, -1))
    assert batch.q.shape == (5, 1, 17) and batch.iterations.shape == (5, 1)
    for i in range(5):
        one = pose_on_terrain(rb, mars, Q[i])
        np.testing.assert_allclose(one.q, batch.q[i, 0], atol=1e-12)
        assert one.iterations == batch.iterations[i, 0] and one.status == "ok"


# ------------------------------------------------------------------ Jacobian
@pytest.mark.parametrize("which", ["rocker_bogie", "rover2d_rocker", "rover2d_prismatic"])
@pytest.mark.parametrize("terrain_kind", ["mars", "waves"])
def test_jacobian_against_finite_differences(which, terrain_kind, mars):
    """dr/dx of the solver's coordinates, and dr/dv along every tangent direction (the
    wheel spin columns are zero: a wheel's rotation does not move its rim)."""
    terrain = mars if terrain_kind == "mars" else _waves()
    mbm = {"rocker_bogie": lambda: rocker_bogie(),
           "rover2d_rocker": lambda: rover2d(suspension="rocker", middle_wheel=True),
           "rover2d_prismatic": lambda: rover2d(suspension="prismatic")}[which]()
    prob = PoseProblem(mbm, terrain)
    rng = np.random.default_rng(5)
    q = place(mbm, 1.3) if mbm.params["planar"] else place(mbm, 1.3, -0.7, yaw=0.4)
    q = prob.step(q, 0.03 * rng.standard_normal(prob.nx))   # off the terrain, loop open
    r, J, _ = prob.evaluate(q)
    assert np.abs(r).max() > 1e-3
    h = 1e-6
    fd = np.column_stack([(prob.evaluate(prob.step(q, h * e), jacobian=False)[0]
                           - prob.evaluate(prob.step(q, -h * e), jacobian=False)[0]) / (2 * h)
                          for e in np.eye(prob.nx)])
    np.testing.assert_allclose(J, fd, atol=1e-6 * max(1.0, np.abs(J).max()))
    _, Jv, _ = prob.evaluate(q, wrt="v")
    model = mbm.model
    fdv = np.column_stack([
        (prob.evaluate(pin.integrate(model, q, h * e), jacobian=False)[0]
         - prob.evaluate(pin.integrate(model, q, -h * e), jacobian=False)[0]) / (2 * h)
        for e in np.eye(model.nv)])
    np.testing.assert_allclose(Jv, fdv, atol=1e-6 * max(1.0, np.abs(Jv).max()))
    spins = [joint_slices(model)[f"wheel_{w.name}"][1].start for w in mbm.wheels]
    assert np.abs(Jv[:, spins]).max() < 1e-9
    # the rows are n^T J_p / n_z with the project's point Jacobian at the rim point
    _, wc = prob.evaluate(q, jacobian=False)[1:]
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    for k, w in enumerate(mbm.wheels):
        fid = model.getFrameId(w.frame)
        Jp = point_jacobian(model, data, fid, wc.point[k] - data.oMf[fid].translation)
        np.testing.assert_allclose(Jv[k], wc.normal[k] @ Jp / wc.normal[k, 2], atol=1e-12)


# ------------------------------------------------------------------ underdetermined
def test_underdetermined_gives_the_nearest_pose():
    """rover2d with struts: 4 unknowns, 2 wheels. The result is the pose nearest the guess
    (SLSQP on |x - x_guess|^2 subject to the same contact equations)."""
    rv = rover2d(suspension="prismatic")
    terrain = _waves()
    guess = place(rv, 0.7)
    guess[3] = 0.02
    pose = pose_on_terrain(rv, terrain, guess)
    assert pose.free == 2 and pose.rank == 2
    prob = PoseProblem(rv, terrain)

    def cons(x):
        return prob.evaluate(prob.step(guess, x), jacobian=False)[0]
    ref = minimize(lambda x: x @ x, np.zeros(4), jac=lambda x: 2 * x, method="SLSQP",
                   constraints=[{"type": "eq", "fun": cons}], options={"ftol": 1e-14,
                                                                      "maxiter": 200})
    assert ref.success
    np.testing.assert_allclose(prob.difference(guess, pose.q), ref.x, atol=1e-6)


@pytest.mark.parametrize("z0", [-4500.0, 20.0, 1500.0])
def test_terrain_at_an_absolute_elevation(z0, mars):
    """A DEM in absolute elevations (Mars's datum at -4500 m, a test site at 1500 m) is
    the same terrain raised by z0: the pose from the nominal guess is the pose on the
    terrain at 0 raised by z0 (translation invariance), for a determined problem
    (rocker-bogie on rough ground) and an underdetermined one (rover2d with struts: the
    nearest pose, which must not be pulled towards a guess z0 away). Before, the steps of
    0.25 m ran out (1500 m: "did not converge in 50 steps")."""
    raised = HeightField(mars.z + z0, (mars.dx, mars.dy), (mars.x0, mars.y0))
    rb = rocker_bogie()
    guess = place(rb, 1.5, -0.7, yaw=0.4)
    low, high = (pose_on_terrain(rb, t, guess) for t in (mars, raised))
    np.testing.assert_allclose(high.q - low.q, np.eye(rb.model.nq)[2] * z0, atol=1e-8)
    assert np.abs(high.gap).max() < 1e-9
    rv = rover2d(suspension="prismatic")
    waves = _waves()
    up = FunctionTerrain(lambda x, y: waves.height(x, y) + z0)
    guess = place(rv, 0.7)
    jz = rv.model.joints[rv.model.getJointId("base_z")].idx_q
    # the guess at its height above the terrain (mean gap 0): the raised terrain's guess
    # is moved by z0 exactly, and the nearest pose to it is the nearest pose raised
    guess[jz] -= PoseProblem(rv, waves).evaluate(guess, jacobian=False)[0][:2].mean()
    low, high = (pose_on_terrain(rv, t, guess) for t in (waves, up))
    np.testing.assert_allclose(high.q - low.q, np.eye(rv.model.nq)[jz] * z0, atol=1e-8)


# ------------------------------------------------------------------ file models
@pytest.mark.parametrize("mbm", [rocker_bogie(), rover2d(suspension="rocker")],
                         ids=["rocker_bogie", "rover2d"])
def test_urdf_export_poses_like_the_builtin(mbm, mars, tmp_path):
    loaded = load_robot(export_urdf(mbm, tmp_path / "rover.urdf"))
    q = place(mbm, 1.0, 0.0) if mbm.params["planar"] else place(mbm, 1.0, 0.5, 0.3)
    a = pose_on_terrain(mbm, mars, q)
    b = pose_on_terrain(loaded, mars, q)
    assert a.solved == b.solved
    np.testing.assert_allclose(b.q, a.q, atol=1e-12)


def test_settling_starts_from_the_pose(monkeypatch):
    """The simulator's settling (rigid drop, then Newton on the static equilibrium) starts
    from the pose on the ground: from a start with the wheels not level (rockers at
    +-0.15 rad, a bogie at -0.2 rad) it settles to the equilibrium it reaches from that
    pose placed by hand; the rigid drop alone (the pose step switched off) fails there."""
    from roverimpact.simulate import run
    from roverimpact.simulate.run import initial_state

    rb = rocker_bogie()
    s = joint_slices(rb.model)
    q0 = np.array(rb.params["q_nominal"])
    q0[s["rocker_left"][0]], q0[s["rocker_right"][0]] = 0.15, -0.15
    q0[s["bogie_left"][0]] = -0.2
    q, _ = initial_state(rb, {}, q0=q0)
    q_hand, _ = initial_state(rb, {}, q0=pose_on_terrain(rb, PlaneTerrain(), q0).q)
    np.testing.assert_allclose(q, q_hand, atol=1e-12)
    monkeypatch.setattr(run, "_pose_on_ground", lambda mbm, sys, q: q)
    with pytest.raises(SolverError, match="static equilibrium"):
        initial_state(rb, {}, q0=q0)


# ------------------------------------------------------------------ errors
def test_rigid_chassis_on_bumps_cannot_touch_with_every_wheel(mars):
    rb = rocker_bogie()
    with pytest.raises(PoseError, match="cannot all touch") as err:
        pose_on_terrain(rb, mars, place(rb, 1.0, 0.5), fixed=rb.lockable_joints)
    msg = str(err.value)
    assert "largest:" in msg and "wheels=" in msg and "left_front" in msg
    assert isinstance(err.value, SolverError)
    assert err.value.result.status == "infeasible"
    assert np.abs(err.value.result.gap).max() > 1e-3
    rv = rover2d(middle_wheel=True)
    with pytest.raises(PoseError, match="cannot all touch"):
        pose_on_terrain(rv, mars, place(rv, 1.0))
    # three wheels on a plane are consistent; on bumps two of them can touch
    pose_on_terrain(rv, PlaneTerrain((0, 0, 0.1), (0.1, 0, 1)), place(rv, 1.0))
    pose = pose_on_terrain(rv, mars, place(rv, 1.0), wheels=["front", "rear"], check=False)
    assert pose.status in ("ok", "penetration")


def test_a_wheel_not_chosen_may_not_penetrate():
    """A bump under the middle wheel: with front and rear on the ground it is inside."""
    bump = FunctionTerrain(lambda x, y: 0.05 * np.exp(-(x / 0.1) ** 2))
    rv = rover2d(middle_wheel=True)
    with pytest.raises(PoseError, match=r"wheel\(s\) \['middle'\].*penetrate"):
        pose_on_terrain(rv, bump, place(rv, 0.0), wheels=["front", "rear"])
    pose = pose_on_terrain(rv, bump, place(rv, 0.0), wheels=["front", "rear"], check=False)
    assert pose.status == "penetration"
    assert pose.gap[pose.wheels.index("middle")] < -0.04


def test_batch_failures_are_named_or_reported(mars):
    rb = rocker_bogie()
    Q = np.array([place(rb, x, 0.5) for x in (-1.0, 0.0, 1.0)])
    with pytest.raises(PoseError, match="pose 0 of 3"):
        pose_on_terrain(rb, mars, Q, fixed=rb.lockable_joints)
    res = pose_on_terrain(rb, mars, Q, fixed=rb.lockable_joints, check=False)
    assert res.status.shape == (3,) and not res.ok.any()


def test_restarts_find_the_poses_gauss_newton_stalls_on():
    """On a rocky field Gauss-Newton stalls where a wheel's lowest rim point jumps between
    two places (13 of 1000 random placements here). Restarts from fixed offsets find a
    pose for each: every wheel touches (brute-force rim scan), the loop is closed, and a
    pose does not depend on the batch it was solved in."""
    rocky = synthetic_mars((20.0, 20.0), 0.05, seed=2, rock_abundance=0.2, d_max=0.5,
                           origin=(-10.0, -10.0))
    rb = rocker_bogie()
    rng = np.random.default_rng(0)
    Q = np.array([place(rb, *rng.uniform(-8.0, 8.0, 2), yaw=rng.uniform(-np.pi, np.pi))
                  for _ in range(300)])
    first = pose_on_terrain(rb, rocky, Q, restarts=0, check=False)
    bad = np.flatnonzero(~first.ok)
    assert bad.size >= 2 and set(first.status[bad]) <= {"stalled", "max_iter", "infeasible"}
    res = pose_on_terrain(rb, rocky, Q[bad])
    assert res.ok.all()
    assert np.abs(res.gap).max() < 1e-9 and np.abs(res.loop_residual).max() < 1e-9
    np.testing.assert_allclose(res.q[:, :2], Q[bad, :2], atol=0)
    for i in range(bad.size):
        g = _rim_clearance(rb, rocky, res.q[i])
        assert np.abs(g).max() < 1e-6, g
    alone = pose_on_terrain(rb, rocky, Q[bad[-1]])
    np.testing.assert_array_equal(alone.q, res.q[-1])
    # poses Gauss-Newton finds at once are not touched by restarts
    good = np.flatnonzero(first.ok)[:20]
    np.testing.assert_array_equal(pose_on_terrain(rb, rocky, Q[good]).q, first.q[good])


def test_bad_input():
    rv = rover2d()
    with pytest.raises(ModelError, match="no wheels"):
        pose_on_terrain(rigid_body(), PlaneTerrain())
    with pytest.raises(InputError, match="unknown or empty wheel list"):
        pose_on_terrain(rv, PlaneTerrain(), wheels=["left"])
    with pytest.raises(InputError, match="unknown or empty wheel list"):
        pose_on_terrain(rv, PlaneTerrain(), wheels=[])
    with pytest.raises(InputError, match="fixed: unknown coordinate"):
        pose_on_terrain(rv, PlaneTerrain(), fixed=["rocker"])
    with pytest.raises(InputError, match="nothing to solve"):
        pose_on_terrain(rv, PlaneTerrain(), fixed=["base_z", "base_pitch"])
    with pytest.raises(InputError, match=r"shape \(\.\.\., 5\)"):
        pose_on_terrain(rv, PlaneTerrain(), np.zeros(4))
    with pytest.raises(InputError, match="needs a terrain"):
        pose_on_terrain(rv, np.zeros((3, 3)))
    small = HeightField(np.zeros((3, 3)), 0.1)
    with pytest.raises(InputError, match="leaves the terrain"):
        pose_on_terrain(rv, small)
    # a terrain function that fails is named as such, not as a wheel off the terrain
    with pytest.raises(InputError, match=r"^pose_on_terrain: wheel_ground_contact: terrain "
                                         r"function is not finite"):
        pose_on_terrain(rv, FunctionTerrain(lambda x, y: np.nan * x))
    with pytest.raises(InputError, match="y and yaw must be 0"):
        place(rv, 0.0, 1.0)
    for bad in (-1, 1.5, True, "8"):
        with pytest.raises(InputError, match="restarts must be a whole number"):
            pose_on_terrain(rv, PlaneTerrain(), restarts=bad)
