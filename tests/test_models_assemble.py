"""Compiled row assembly (models._assemble) against the per-constraint reference rows and
against finite differences of the contact points.

The reference ``ConstraintSet.rows`` builds each row from ``pin.getFrameJacobian`` (frame
Jacobian, LOCAL_WORLD_ALIGNED) one constraint at a time; the compiled path uses the world
joint Jacobian ``data.J`` with the frame's support mask. They must agree to rounding at
random configurations (tilted chassis, bent suspension, tilted wheel axes), for wheels on
tilted planes, no-slip rows, points in frames, locked joints and the loop closure.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from roverimpact.exceptions import ModelError
from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.base import MultibodyModel
from roverimpact.models.constraints import (
    GroundContact,
    LockedJoint,
    LoopClosure,
    PointContact,
    mass_matrix,
    wheel_contact_point,
)
from roverimpact.models.kinematics import ConstraintSet


def _random_q(model, rng, scale=0.4):
    """Neutral configuration moved by a random tangent vector (valid quaternions)."""
    return pin.integrate(model, pin.neutral(model), scale * rng.standard_normal(model.nv))


def _constraints(mbm, rng):
    tilt = rng.standard_normal(3) * 0.3 + np.array([0.0, 0.0, 1.0])
    tilt /= np.linalg.norm(tilt)
    cons = [GroundContact(w, noslip=True, planar=mbm.params.get("planar", False),
                          normal=tuple(tilt if k == 0 else (0.0, 0.0, 1.0)))
            for k, w in enumerate(mbm.wheels)]
    if mbm.loop_closure is not None:
        cons.append(LoopClosure(tuple(mbm.loop_names)))
    if mbm.lockable_joints:
        cons.append(LockedJoint(mbm.lockable_joints[0]))
    w = mbm.wheels[0]
    beta = rng.uniform(0.0, np.pi / 2)
    cons.append(PointContact("obs", w.frame, (-np.sin(beta), 0.0, np.cos(beta)), wheel=w))
    cons.append(PointContact("pt", mbm.wheels[-1].frame, (0.0, 0.6, 0.8),
                             point=tuple(rng.standard_normal(3) * 0.1)))
    return cons


@pytest.mark.parametrize("build", [lambda: rover2d(suspension="rocker", middle_wheel=True),
                                   rover2d, rocker_bogie])
def test_compiled_rows_equal_reference_rows(build):
    rng = np.random.default_rng(7)
    mbm = build()
    cs = ConstraintSet(mbm, _constraints(mbm, rng))
    for _ in range(5):
        q = _random_q(mbm.model, rng)
        M, A = cs.evaluate(q)
        cs.kinematics(q)
        ref = cs.rows(q)
        assert A.shape == ref.shape == (len(cs.labels), mbm.model.nv)
        np.testing.assert_allclose(A, ref, rtol=0, atol=1e-12 * max(1.0, np.abs(ref).max()))
        np.testing.assert_allclose(M, mass_matrix(mbm.model, mbm.model.createData(), q),
                                   rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(M, M.T)


def test_compiled_wheel_row_matches_finite_differences():
    """The velocity of the rim point along n equals d/dt of its position (frozen point)."""
    rng = np.random.default_rng(3)
    mbm = rocker_bogie()
    w = mbm.wheels[2]
    n = np.array([-0.5, 0.1, 0.86])
    n /= np.linalg.norm(n)
    cs = ConstraintSet(mbm, [PointContact("obs", w.frame, tuple(n), wheel=w)])
    model, data = mbm.model, mbm.model.createData()
    fid = model.getFrameId(w.frame)
    q = _random_q(model, rng)
    _, A = cs.evaluate(q)
    # the rim point, frozen in the wheel body, moved along a random velocity
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    p = wheel_contact_point(data, fid, w, n)
    local = data.oMf[fid].actInv(p)
    v = rng.standard_normal(model.nv)
    h = 1e-7

    def point(qq):
        pin.forwardKinematics(model, data, qq)
        pin.updateFramePlacements(model, data)
        return data.oMf[fid].act(local)

    fd = (point(pin.integrate(model, q, h * v)) - point(pin.integrate(model, q, -h * v))) / (2 * h)
    assert A[0] @ v == pytest.approx(n @ fd, rel=1e-6, abs=1e-9)


def _custom_loop_rover():
    """rover2d (rocker) with a loop closure whose Jacobian depends on q: its row is
    cos(q_j) on joint j's rate. Returns the model, its Pinocchio model, joint j and the
    rover2d it came from."""
    base = rover2d(suspension="rocker")
    model = base.model
    j = model.joints[1]

    def loop(q):
        J = np.zeros((1, model.nv))
        J[0, j.idx_v] = np.cos(q[j.idx_q])
        return np.zeros(1), J

    mbm = MultibodyModel(model=model, name="x", wheels=base.wheels, loop_closure=loop,
                         loop_names=["custom"], params=base.params)
    return mbm, model, j, base


def test_nonlinear_loop_closure_is_recomputed():
    """A loop closure whose Jacobian depends on q is evaluated at every call."""
    mbm, model, j, _ = _custom_loop_rover()
    cs = ConstraintSet(mbm, [LoopClosure(("custom",))])
    for a in (0.1, 0.7):
        q = pin.neutral(model)
        q[j.idx_q] = a
        _, A = cs.evaluate(q)
        assert A[0, j.idx_v] == pytest.approx(np.cos(a), rel=1e-14)


# ----------------------------------------------------------------------------------------
# Batched evaluation over configurations, URDF robots, placements read in place
# ----------------------------------------------------------------------------------------


def _panda(floating_base=False):
    from roverimpact.models import load_robot

    return load_robot("example-robot-data:panda_description/urdf/panda.urdf",
                      floating_base=floating_base)


def _arm_constraints(mbm, rng):
    """Two points on the hand and the elbow with random normals, and a locked joint."""
    cons = []
    for name, frame in (("tool", "panda_hand_tcp"), ("elbow", "panda_link4")):
        n = rng.standard_normal(3)
        cons.append(PointContact(name, frame, tuple(n / np.linalg.norm(n)),
                                 point=tuple(0.05 * rng.standard_normal(3))))
    cons.append(LockedJoint("panda_joint3"))
    return cons


def _reference(cs, mbm, q):
    """M by CRBA on fresh data, A from the per-constraint rows (pin.getFrameJacobian)."""
    cs.kinematics(q)
    return mass_matrix(mbm.model, mbm.model.createData(), q), cs.rows(q)


_CASES = {
    "rover2d_rocker_mid": lambda rng: (lambda m: (m, _constraints(m, rng)))(
        rover2d(suspension="rocker", middle_wheel=True)),
    "rocker_bogie": lambda rng: (lambda m: (m, _constraints(m, rng)))(rocker_bogie()),
    "panda_urdf": lambda rng: (lambda m: (m, _arm_constraints(m, rng)))(_panda()),
    "panda_urdf_floating": lambda rng: (lambda m: (m, _arm_constraints(m, rng)))(
        _panda(floating_base=True)),
}


@pytest.mark.parametrize("case", sorted(_CASES))
def test_batched_evaluate_equals_reference_rows(case):
    """evaluate(Q) with Q (2, 3, nq) gives, item by item, the CRBA mass matrix and the
    per-constraint reference rows, to 1e-12 relative; and the single-q path agrees."""
    rng = np.random.default_rng(11)
    mbm, cons = _CASES[case](rng)
    cs = ConstraintSet(mbm, cons)
    Q = np.array([_random_q(mbm.model, rng, 0.6) for _ in range(6)]).reshape(2, 3, -1)
    M, A = cs.evaluate(Q)
    nv, m = mbm.model.nv, len(cs.labels)
    assert M.shape == (2, 3, nv, nv) and A.shape == (2, 3, m, nv)
    for idx in np.ndindex(2, 3):
        M_ref, A_ref = _reference(cs, mbm, Q[idx])
        scale = max(1.0, np.abs(A_ref).max())
        np.testing.assert_allclose(A[idx], A_ref, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(M[idx], M_ref, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(M[idx], M[idx].T)
        M1, A1 = cs.evaluate(Q[idx])
        np.testing.assert_allclose(A1, A[idx], rtol=0, atol=1e-14 * scale)
        np.testing.assert_array_equal(M1, M[idx])


def test_point_row_of_urdf_arm_matches_finite_differences():
    """Row a of a point fixed in a Panda link: a v = n . d/dt p(q + t v) (central differences
    of the point position from forward kinematics alone)."""
    rng = np.random.default_rng(5)
    mbm = _panda(floating_base=True)
    model = mbm.model
    n = np.array([0.3, -0.2, 0.93])
    n /= np.linalg.norm(n)
    x = np.array([0.02, -0.01, 0.07])
    cs = ConstraintSet(mbm, [PointContact("tool", "panda_link6", tuple(n), point=tuple(x))])
    fid = model.getFrameId("panda_link6")
    data = model.createData()

    def point(qq):
        pin.framesForwardKinematics(model, data, qq)
        return data.oMf[fid].act(x)

    Q = np.array([_random_q(model, rng, 0.8) for _ in range(4)])
    _, A = cs.evaluate(Q)
    h = 1e-6
    for q, a in zip(Q, A[:, 0], strict=True):
        v = rng.standard_normal(model.nv)
        fd = (point(pin.integrate(model, q, h * v)) - point(pin.integrate(model, q, -h * v)))
        assert a @ v == pytest.approx(n @ fd / (2 * h), rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("view, attr", [("_placement_view", "_oMf"),
                                        ("_jacobian_view", "_Jt")])
def test_placements_fallback_equals_in_place_view(monkeypatch, view, attr):
    """With the in-place view of data.oMf (or of data.J) unavailable (as on a Pinocchio
    build with another memory layout), the frame-by-frame copy (the copy of data.J per
    pass) gives the same rows, single and batched, and the same partition at one
    configuration (the plan built that way from the start, its packed arrays and short
    paths included)."""
    from roverimpact.models import _assemble

    rng = np.random.default_rng(2)
    mbm = rocker_bogie()
    constraints = _constraints(mbm, rng)
    cs = ConstraintSet(mbm, constraints)
    Q = np.array([_random_q(mbm.model, rng) for _ in range(5)])
    M, A = cs.evaluate(Q)
    assert getattr(cs._row_plan(), attr) is not None  # the installed Pinocchio: in place
    monkeypatch.setattr(_assemble, view, lambda data, n: None)
    cs2 = ConstraintSet(mbm, constraints)
    assert getattr(cs2._row_plan(), attr) is None
    M2, A2 = cs2.evaluate(Q)
    np.testing.assert_array_equal(M2, M)
    np.testing.assert_array_equal(A2, A)
    rows = np.arange(A.shape[1], dtype=np.int64)
    v = rng.standard_normal(A.shape[2])
    for q, a in zip(Q, A, strict=True):
        np.testing.assert_array_equal(cs2.evaluate(q)[1], a)
        res, res2 = np.empty(4), np.empty(4)
        assert cs.partition_at(q, rows, v, 1e-9, res) == cs2.partition_at(q, rows, v, 1e-9,
                                                                          res2)
        np.testing.assert_array_equal(res2, res)


def test_copied_constraint_set_reads_its_own_data():
    """A deep copy or pickle round trip rebuilds the plan on the copy's own Pinocchio data
    (the in-place view must not keep reading the original's memory)."""
    import copy
    import pickle

    rng = np.random.default_rng(4)
    mbm = rocker_bogie()
    cs = ConstraintSet(mbm, _constraints(mbm, rng))
    q1, q2 = _random_q(mbm.model, rng), _random_q(mbm.model, rng)
    _, A1 = cs.evaluate(q1)
    for other in (copy.deepcopy(cs), pickle.loads(pickle.dumps(cs))):
        _, A2 = other.evaluate(q2)
        cs.evaluate(q1)  # moves the original's data after the copy evaluated
        np.testing.assert_allclose(A2, _reference(other, mbm, q2)[1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(other.evaluate(q1)[1], A1, rtol=0, atol=1e-14)


def test_one_dof_pendulum_single_and_batched(tmp_path):
    """nv = 1 (Pinocchio returns 1-D arrays): M = I_yy + m c^2, and the row of the bob
    point (l, 0, 0) along x is d/dt (l cos q) = -l sin q (hinge about y, z up: x = l cos q,
    z = -l sin q)."""
    from roverimpact.models import load_robot

    m, c, l, Iyy = 2.0, 0.3, 0.5, 0.04
    f = tmp_path / "pend.urdf"
    f.write_text(f"""<robot name="pend"><link name="base"/>
  <link name="arm"><inertial><origin xyz="{c} 0 0"/><mass value="{m}"/>
    <inertia ixx="0.01" iyy="{Iyy}" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>""")
    mbm = load_robot(f)
    cs = ConstraintSet(mbm, [PointContact("bob", "arm", (1.0, 0.0, 0.0), point=(l, 0.0, 0.0))])
    Q = np.array([[0.0], [0.4], [-1.1]])
    M, A = cs.evaluate(Q)
    assert M.shape == (3, 1, 1) and A.shape == (3, 1, 1)
    np.testing.assert_allclose(M[:, 0, 0], Iyy + m * c**2, rtol=1e-14)
    np.testing.assert_allclose(A[:, 0, 0], -l * np.sin(Q[:, 0]), rtol=0, atol=1e-15)
    M1, A1 = cs.evaluate(Q[1])
    assert M1.shape == (1, 1) and A1.shape == (1, 1)
    assert A1[0, 0] == pytest.approx(-l * np.sin(0.4), abs=1e-15)


def test_nonlinear_loop_closure_batched():
    """Batched evaluation recomputes a q-dependent loop closure for every item."""
    mbm, model, j, base = _custom_loop_rover()
    cs = ConstraintSet(mbm, [LoopClosure(("custom",)), GroundContact(base.wheels[0])])
    Q = np.repeat(pin.neutral(model)[None], 3, axis=0)
    Q[:, j.idx_q] = (0.1, 0.7, -0.3)
    _, A = cs.evaluate(Q)
    np.testing.assert_allclose(A[:, 0, j.idx_v], np.cos(Q[:, j.idx_q]), rtol=1e-14)
    for q, a in zip(Q, A, strict=True):
        np.testing.assert_allclose(a, _reference(cs, mbm, q)[1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad", [np.zeros(3), np.zeros((2, 5)), 1.0])
def test_wrong_configuration_shape_is_a_model_error(bad):
    mbm = rocker_bogie()
    cs = ConstraintSet(mbm, [LoopClosure(tuple(mbm.loop_names))])
    with pytest.raises(ModelError, match=r"q must have shape \(\.\.\., 17\)"):
        cs.evaluate(bad)


# ----------------------------------------------------------------------------------------
# One configuration to T_c in one compiled call (ConstraintSet.partition_at, ImpactSetup.T_c_at)
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", sorted(_CASES))
def test_partition_at_equals_evaluate_then_partition(case):
    """The fused path gives ``partition(M, A[rows], v)`` on the arrays of ``evaluate`` to
    rounding (the same compiled functions, compiled for other argument types), and T_c is
    1/2 (A v)^T (A M^-1 A^T)^-1 (A v) for independent rows (numpy solve on the reference
    rows, a second method)."""
    from roverimpact import partition

    rng = np.random.default_rng(3)
    mbm, cons = _CASES[case](rng)
    cs = ConstraintSet(mbm, cons)
    for _ in range(4):
        q = _random_q(mbm.model, rng, 0.2)
        v = rng.standard_normal(mbm.model.nv)
        rows = np.sort(rng.choice(len(cs.labels), size=min(3, len(cs.labels)),
                                  replace=False)).astype(np.int64)
        res = np.empty(4)
        assert cs.partition_at(q, rows, v, 1e-9, res) == 0
        M, A = cs.evaluate(q)
        p = partition(M, A[rows], v, want_velocities=False)
        np.testing.assert_allclose(res[:3], [p.T, p.T_c, p.T_a], rtol=1e-13,
                                   atol=1e-15 * p.T)
        assert int(res[3]) == p.rank
        Mr, Ar = _reference(cs, mbm, q)
        Ar = Ar[rows]
        if np.linalg.matrix_rank(Ar) == len(rows):
            g = Ar @ v
            ref = 0.5 * g @ np.linalg.solve(Ar @ np.linalg.solve(Mr, Ar.T), g)
            assert res[1] == pytest.approx(ref, rel=1e-9)


def test_partition_at_recomputes_a_nonlinear_loop_and_takes_one_dof(tmp_path):
    """A q-dependent loop closure is evaluated at each call; nv = 1 (Pinocchio's 1-D
    arrays) works: T_c of the pendulum's bob row is 1/2 (a v)^2 / (a M^-1 a)."""
    from roverimpact import partition
    from roverimpact.models import load_robot

    mbm, model, j, base = _custom_loop_rover()
    cs = ConstraintSet(mbm, [LoopClosure(("custom",)), GroundContact(base.wheels[0])])
    v = np.linspace(-1.0, 1.0, model.nv)
    rows = np.array([0, 1], dtype=np.int64)
    for a in (0.1, 0.7):
        q = pin.neutral(model)
        q[j.idx_q] = a
        res = np.empty(4)
        assert cs.partition_at(q, rows, v, 1e-9, res) == 0
        M, A = cs.evaluate(q)
        assert res[1] == pytest.approx(partition(M, A, v, want_velocities=False).T_c,
                                       rel=1e-13)
    f = tmp_path / "pend.urdf"
    f.write_text("""<robot name="pend"><link name="base"/>
  <link name="arm"><inertial><origin xyz="0.3 0 0"/><mass value="2"/>
    <inertia ixx="0.01" iyy="0.04" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>""")
    pend = ConstraintSet(load_robot(f), [PointContact("bob", "arm", (1.0, 0.0, 0.0),
                                                      point=(0.5, 0.0, 0.0))])
    res = np.empty(4)
    assert pend.partition_at(np.array([0.4]), np.array([0], np.int64), np.array([2.0]),
                             1e-9, res) == 0
    a, m = -0.5 * np.sin(0.4), 0.04 + 2.0 * 0.3**2
    assert res[1] == pytest.approx(0.5 * (a * 2.0) ** 2 / (a * a / m), rel=1e-13)


@pytest.mark.parametrize("build", [rover2d, rocker_bogie, lambda: _panda(True)])
def test_world_convention_crba_makes_the_joint_jacobians_and_placements_to_the_bit(build):
    """The compiled path takes M from CRBA in Pinocchio's world convention and the world
    joint Jacobian data.J that it fills on the way (models._assemble._WORLD): data.J and the
    frame placements equal those of pin.computeJointJacobians to the bit, M the
    local-convention CRBA to rounding, and the plan's (M, A) the per-constraint reference
    (local CRBA, pin.getFrameJacobian)."""
    rng = np.random.default_rng(3)
    mbm = build()
    model = mbm.model
    local, world = model.createData(), model.createData()
    iu = np.triu_indices(model.nv)
    for _ in range(5):
        q = _random_q(model, rng)
        M_local = pin.crba(model, local, q).copy()
        J_local = pin.computeJointJacobians(model, local, q).copy()
        pin.updateFramePlacements(model, local)
        M_world = pin.crba(model, world, q, pin.Convention.WORLD)
        pin.updateFramePlacements(model, world)
        assert np.array_equal(world.J, J_local)
        for a, b in zip(world.oMf, local.oMf, strict=True):
            assert np.array_equal(a.homogeneous, b.homogeneous)
        scale = np.abs(M_local[iu]).max()
        assert np.abs(M_world[iu] - M_local[iu]).max() <= 1e-14 * scale
    cons = (_arm_constraints(mbm, rng) if model.name.startswith("panda")
            else _constraints(mbm, rng))
    cs = ConstraintSet(mbm, cons)
    for _ in range(3):
        q = _random_q(model, rng)
        M, A = cs.evaluate(q)
        cs.kinematics(q)
        np.testing.assert_allclose(M, mass_matrix(model, local, q), rtol=0,
                                   atol=1e-13 * np.abs(M).max())
        np.testing.assert_allclose(A, cs.rows(q), rtol=0, atol=1e-12)
