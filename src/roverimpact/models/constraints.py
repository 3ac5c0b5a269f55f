r"""Mass matrix and constraint rows of a :class:`MultibodyModel`, from Pinocchio.

Every constraint is a set of rows of :math:`A` (``A v = 0``) written in the world frame
at a contact point :math:`p` rigidly attached to a frame :math:`F` (origin :math:`o_F`):

.. math::

    v_p = J_{lin} v + \omega \times (p - o_F) = (J_{lin} - [p - o_F]_\times J_{ang})\, v,
    \qquad a = n^T (J_{lin} - [r]_\times J_{ang}) = n^T J_{lin} + (r \times n)^T J_{ang}

with :math:`[J_{lin}; J_{ang}]` the ``LOCAL_WORLD_ALIGNED`` frame Jacobian of :math:`F`
(``pin.getFrameJacobian``) and :math:`r = p - o_F` in world axes. Contact rows are
oriented so that ``a v < 0`` when the bodies approach (``n`` is the outward normal of the
fixed surface, pointing towards the moving body), as in :mod:`roverimpact.impulse`.

Row labels: ``"ground:<wheel>:normal"``, ``"ground:<wheel>:long"`` (no-slip along the
rolling direction), ``"ground:<wheel>:lat"`` (no-slip across, 3-D only),
``"obstacle:<name>:normal"``, ``"point:<name>:normal|long|lat"`` (declared contacts),
``"loop:<name>"``, ``"lock:<joint>"``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from .base import Wheel

__all__ = [
    "RIM_AXIS_TOL",
    "GroundContact",
    "LockedJoint",
    "LoopClosure",
    "PointContact",
    "loop_jdot_v",
    "mass_matrix",
    "point_jacobian",
    "wheel_contact_point",
]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

#: A unit normal whose part across a wheel's axis is shorter than this is along the axis
#: (a face hit: no rim point faces it). Every rim-point rule uses it: the row assembly,
#: the scenario's batch over beta, the traverse's impact models.
RIM_AXIS_TOL = 1e-9


def mass_matrix(model, data, q) -> np.ndarray:
    """Joint-space mass matrix M(q) (n x n) by Pinocchio's CRBA, upper triangle symmetrized."""
    M = pin.crba(model, data, np.asarray(q, dtype=float))
    return np.triu(M) + np.triu(M, 1).T


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def _cross(a, b) -> np.ndarray:
    """Cross product of two 3-vectors (np.cross is ~50x slower for one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def point_jacobian(model, data, frame_id: int, r_world) -> np.ndarray:
    """Velocity Jacobian (3, nv) of the point at ``o_F + r_world`` rigidly attached to a frame.

    Requires ``pin.computeJointJacobians`` and ``pin.updateFramePlacements`` on ``data``.
    """
    # pinocchio returns a 1-D array for nv = 1: keep the (6, nv) shape
    J = np.asarray(pin.getFrameJacobian(model, data, frame_id, _LWA)).reshape(6, model.nv)
    return J[:3] - _skew(np.asarray(r_world, dtype=float)) @ J[3:]


def loop_jdot_v(closure, model, q, v, k: int | None = None) -> np.ndarray:
    r"""The bias term :math:`\dot J_l v` (k,) of a loop closure ``q -> (phi (k,), J_l (k, nv))``.

    ``0`` for a closure whose ``J_l`` does not depend on ``q`` (attribute
    ``constant_jacobian``); a closure's own ``jdot_v(q, v)`` if it has one; else the central
    difference of ``J_l`` along ``v`` on the manifold,
    ``(J_l(q + eps v) - J_l(q - eps v)) v / (2 eps)``, ``eps = 1e-6 / max(1, |v|_inf)``.
    ``k``: the number of rows, if known (spares an evaluation of a constant closure).
    """
    if getattr(closure, "constant_jacobian", False):
        if k is None:
            k = np.atleast_1d(np.asarray(closure(q)[0])).shape[0]
        return np.zeros(k)
    own = getattr(closure, "jdot_v", None)
    if own is not None:
        return own(q, v)
    eps = 1e-6 / max(1.0, float(np.max(np.abs(v))))
    Jp = np.atleast_2d(np.asarray(closure(pin.integrate(model, q, eps * v))[1], float))
    Jm = np.atleast_2d(np.asarray(closure(pin.integrate(model, q, -eps * v))[1], float))
    return (Jp - Jm) @ v / (2 * eps)


def _unit(x, what: str) -> np.ndarray:
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise ModelError(f"{what} must be 3 finite numbers, got {x.tolist()}")
    nrm = np.linalg.norm(x)
    if not nrm > 1e-12:
        raise ModelError(f"{what} has zero length: give a non-zero direction")
    return x / nrm


def wheel_contact_point(data, frame_id: int, wheel: Wheel, n) -> np.ndarray:
    """World position of the point of a wheel's rim facing a surface of outward normal ``n``.

    The rim point is ``c - r d`` with ``d`` the unit part of ``n`` orthogonal to the wheel
    axis (for an upright wheel on flat ground, the lowest point of the wheel).
    """
    oMf = data.oMf[frame_id]
    a = oMf.rotation @ np.asarray(wheel.axis, dtype=float)
    n = np.asarray(n, dtype=float)
    d = n - (n @ a) * a
    nd = np.sqrt(d @ d)
    d = n if nd < RIM_AXIS_TOL else d / nd
    return oMf.translation - wheel.radius * d


@dataclass(frozen=True)
class GroundContact:
    """Wheel on a plane of outward normal ``normal``: normal row, optional no-slip rows."""

    wheel: Wheel
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    noslip: bool = False
    planar: bool = False

    def labels(self) -> list[str]:
        out = [f"ground:{self.wheel.name}:normal"]
        if self.noslip:
            out.append(f"ground:{self.wheel.name}:long")
            if not self.planar:
                out.append(f"ground:{self.wheel.name}:lat")
        return out

    def rows(self, model, data, fid) -> np.ndarray:
        n = np.asarray(self.normal, dtype=float)
        p = wheel_contact_point(data, fid, self.wheel, n)
        Jp = point_jacobian(model, data, fid, p - data.oMf[fid].translation)
        dirs = [n]
        if self.noslip:
            a = data.oMf[fid].rotation @ np.asarray(self.wheel.axis, dtype=float)
            t = _cross(a, n)
            t /= np.sqrt(t @ t)
            dirs.append(t)
            if not self.planar:
                dirs.append(_cross(n, t))
        return np.array(dirs) @ Jp


@dataclass(frozen=True)
class PointContact:
    """Impact (or any) normal row at a point: on a wheel rim, or at ``point`` in a frame.

    ``normal`` is the outward unit normal of the obstacle face (world), pointing towards
    the moving body; approaching means ``a v < 0``.
    """

    name: str
    frame: str
    normal: tuple[float, float, float]
    point: tuple[float, float, float] | None = (0.0, 0.0, 0.0)
    wheel: Wheel | None = None
    label: str | None = None

    def labels(self) -> list[str]:
        return [self.label or f"obstacle:{self.name}:normal"]

    def contact_point(self, data, fid) -> np.ndarray:
        if self.wheel is not None:
            return wheel_contact_point(data, fid, self.wheel, self.normal)
        return data.oMf[fid].act(np.asarray(self.point, dtype=float))

    def rows(self, model, data, fid) -> np.ndarray:
        p = self.contact_point(data, fid)
        Jp = point_jacobian(model, data, fid, p - data.oMf[fid].translation)
        return (np.asarray(self.normal, dtype=float) @ Jp)[None, :]


@dataclass(frozen=True)
class LoopClosure:
    """All loop-closure rows of the model (``J`` of ``loop_closure(q)``)."""

    names: tuple[str, ...]

    def labels(self) -> list[str]:
        return [f"loop:{n}" for n in self.names]


@dataclass(frozen=True)
class LockedJoint:
    """A locked joint: its velocity components are zero."""

    joint: str

    def labels(self) -> list[str]:
        return [f"lock:{self.joint}"]
