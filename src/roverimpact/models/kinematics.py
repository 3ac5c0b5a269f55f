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
``"obstacle:<name>:normal"``, ``"loop:<name>"``, ``"lock:<joint>"``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from .base import MultibodyModel, Wheel

__all__ = [
    "ConstraintSet",
    "GroundContact",
    "LockedJoint",
    "LoopClosure",
    "PointContact",
    "mass_matrix",
    "point_jacobian",
    "wheel_contact_point",
]

_LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


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
    d = n if nd < 1e-9 else d / nd
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

    def labels(self) -> list[str]:
        return [f"obstacle:{self.name}:normal"]

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


@dataclass
class ConstraintSet:
    """Constraints of a model evaluated together: ``evaluate(q) -> (M, A)``.

    One call runs the CRBA, the joint Jacobians and the frame placements once and stacks
    the rows of every constraint in order; ``labels`` names each row.

    Parameters
    ----------
    mbm : MultibodyModel
    constraints : list
        :class:`GroundContact`, :class:`PointContact`, :class:`LoopClosure`,
        :class:`LockedJoint` items.
    """

    mbm: MultibodyModel
    constraints: list
    labels: list[str] = field(init=False)
    _fids: list = field(init=False, repr=False)
    _data: object = field(init=False, repr=False)
    _plan: object = field(init=False, repr=False, default=None)

    def __post_init__(self):
        model = self.mbm.model
        self._data = model.createData()
        self.labels = []
        self._fids = []
        for c in self.constraints:
            fid = None
            if isinstance(c, GroundContact):
                fid = _frame_id(model, c.wheel.frame)
            elif isinstance(c, PointContact):
                fid = _frame_id(model, c.frame)
            elif isinstance(c, LockedJoint):
                if not model.existJointName(c.joint):
                    raise ModelError(
                        f"cannot lock unknown joint {c.joint!r}; joints: {list(model.names[1:])}"
                    )
            elif isinstance(c, LoopClosure):
                if self.mbm.loop_closure is None:
                    raise ModelError(f"model {self.mbm.name!r} has no loop closure")
            else:  # pragma: no cover - programming error
                raise TypeError(f"unknown constraint {c!r}")
            self._fids.append(fid)
            self.labels.extend(c.labels())

    @property
    def data(self):
        return self._data

    def __getstate__(self):
        # the compiled row plan reads ``_data``'s memory in place: rebuild it after a copy
        state = self.__dict__.copy()
        state["_plan"] = None
        return state

    def kinematics(self, q) -> None:
        """Forward kinematics, joint Jacobians and frame placements at ``q``."""
        model, data = self.mbm.model, self._data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)

    def rows(self, q) -> np.ndarray:
        """A (m, nv) at ``q`` (after :meth:`kinematics` at the same ``q``)."""
        model, data = self.mbm.model, self._data
        out = []
        for c, fid in zip(self.constraints, self._fids, strict=True):
            if fid is not None:
                out.append(c.rows(model, data, fid))
            elif isinstance(c, LoopClosure):
                out.append(self.mbm.loop_closure(q)[1])
            else:
                j = model.joints[model.getJointId(c.joint)]
                r = np.zeros((j.nv, model.nv))
                r[np.arange(j.nv), j.idx_v + np.arange(j.nv)] = 1.0
                out.append(r)
        if not out:
            return np.zeros((0, model.nv))
        return np.vstack(out)

    def _row_plan(self):
        if self._plan is None:
            from ._assemble import RowPlan

            self._plan = RowPlan(self)
        return self._plan

    def fast_rows(self, q) -> np.ndarray:
        """The same ``A`` as :meth:`rows` at ``q``, from the compiled path
        (:mod:`roverimpact.models._assemble`; runs its own kinematics)."""
        return self.evaluate(q)[1]

    def evaluate(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``(M, A)`` at one configuration or a batch of them.

        One Pinocchio pass per configuration (CRBA, joint Jacobians, frame placements);
        every row of ``A`` is assembled in one compiled call
        (:mod:`roverimpact.models._assemble`), for a batch in one call over all items.
        The per-constraint :meth:`rows` is the readable reference for the same rows.

        Parameters
        ----------
        q : (..., nq) array_like
            Configuration(s).

        Returns
        -------
        M : (..., nv, nv) ndarray
            Joint-space mass matrix (Pinocchio CRBA, symmetric).
        A : (..., m, nv) ndarray
            Constraint rows in the order of :attr:`labels`.
        """
        q = np.asarray(q, dtype=float)
        nq = self.mbm.model.nq
        if q.ndim == 0 or q.shape[-1] != nq:
            raise ModelError(f"q must have shape (..., {nq}) for model {self.mbm.name!r}, "
                             f"got {q.shape}")
        plan = self._plan if self._plan is not None else self._row_plan()
        if q.ndim == 1:
            return plan.evaluate(q)
        batch = q.shape[:-1]
        M, A = plan.evaluate_many(np.ascontiguousarray(q.reshape(-1, nq)))
        return M.reshape(*batch, *M.shape[1:]), A.reshape(*batch, *A.shape[1:])


def _frame_id(model, name: str) -> int:
    if not model.existFrame(name):
        known = sorted({f.name for f in model.frames})
        raise ModelError(f"unknown frame/body {name!r}; the model has frames {known}")
    return model.getFrameId(name)
