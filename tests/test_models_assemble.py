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

from roverimpact.models import rocker_bogie, rover2d
from roverimpact.models.base import MultibodyModel
from roverimpact.models.kinematics import (
    ConstraintSet,
    GroundContact,
    LockedJoint,
    LoopClosure,
    PointContact,
    mass_matrix,
    wheel_contact_point,
)


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


def test_nonlinear_loop_closure_is_recomputed():
    """A loop closure whose Jacobian depends on q is evaluated at every call."""
    base = rover2d(suspension="rocker")
    model = base.model
    j = model.joints[1]

    def loop(q):
        J = np.zeros((1, model.nv))
        J[0, j.idx_v] = np.cos(q[j.idx_q])
        return np.zeros(1), J

    mbm = MultibodyModel(model=model, name="x", wheels=base.wheels, loop_closure=loop,
                         loop_names=["custom"], params=base.params)
    cs = ConstraintSet(mbm, [LoopClosure(("custom",))])
    for a in (0.1, 0.7):
        q = pin.neutral(model)
        q[j.idx_q] = a
        _, A = cs.evaluate(q)
        assert A[0, j.idx_v] == pytest.approx(np.cos(a), rel=1e-14)
