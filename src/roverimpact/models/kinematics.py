"""Mass matrix and constraint rows of a :class:`MultibodyModel` together, from Pinocchio.

:class:`ConstraintSet` evaluates a list of constraints (:mod:`.constraints`) at one or many
configurations: the readable per-constraint rows (:meth:`ConstraintSet.rows`) and the
compiled assembly of every row in one pass (:mod:`._assemble`).
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..exceptions import ModelError
from ._assemble import RowPlan
from .base import MultibodyModel
from .constraints import GroundContact, LockedJoint, LoopClosure, PointContact
from .joints import UNIT_TOL, check_configuration

__all__ = ["ConstraintSet"]


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

    Threads: each thread that uses a set gets its own Pinocchio ``data`` and row plan
    (:attr:`data`, made on its first call), as Pinocchio's models are shared and its data
    are not; the compiled kernels read that data with the GIL released. Threads that
    share a set (an :class:`~roverimpact.scenario.ImpactSetup` and its ``T_c_at``,
    ``evaluate`` and :func:`~roverimpact.scenario.sweep_energy`) get the results of one
    thread, where two Pinocchio passes on one data at once gave wrong numbers.
    :meth:`evaluate_members` writes each member's numbers into the model itself: it holds
    :attr:`lock`, so threads sharing the set take turns there (sets built on one model
    do not share it).
    """

    mbm: MultibodyModel
    constraints: list
    labels: list[str] = field(init=False)
    _fids: list = field(init=False, repr=False)

    def __post_init__(self):
        model = self.mbm.model
        self._local = threading.local()  # each thread's data and row plan (see data)
        self.lock = threading.Lock()
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
        """The Pinocchio data of the calling thread (made on its first use)."""
        try:
            return self._local.data
        except AttributeError:
            data = self._local.data = self.mbm.model.createData()
            return data

    def __getstate__(self):
        # the row plans read their data's memory in place, and neither the threads' data
        # nor a lock pickles: a copy makes its own
        state = self.__dict__.copy()
        del state["lock"], state["_local"]
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._local = threading.local()
        self.lock = threading.Lock()

    def kinematics(self, q) -> None:
        """Forward kinematics, joint Jacobians and frame placements at ``q``."""
        model, data = self.mbm.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)

    def rows(self, q) -> np.ndarray:
        """A (m, nv) at ``q`` (after :meth:`kinematics` at the same ``q``)."""
        model, data = self.mbm.model, self.data
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
        """The calling thread's row plan (on its :attr:`data`), made on first use."""
        try:
            return self._local.plan
        except AttributeError:
            plan = self._local.plan = RowPlan(self)
            return plan

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
        check_configuration(self.mbm.model, q)
        try:
            plan = self._local.plan
        except AttributeError:
            plan = self._row_plan()
        if q.ndim == 1:
            return plan.evaluate(q)
        batch = q.shape[:-1]
        M, A = plan.evaluate_many(np.ascontiguousarray(q.reshape(-1, nq)))
        return M.reshape(*batch, *M.shape[1:]), A.reshape(*batch, *A.shape[1:])

    def partition_at(self, q, rows, v, rtol: float, res: np.ndarray) -> int:
        """Kinetic-energy partition of the rows ``rows`` (int64 indices into :attr:`labels`)
        at one configuration ``q`` (nq,) with velocity ``v`` (nv,), in one compiled call
        after the Pinocchio pass: ``res`` (4,) receives ``T, T_c, T_a`` and the rank.
        Returns the partition's status code (0: done; otherwise the checks of
        :func:`roverimpact.partition` failed, and :meth:`evaluate` gives the arrays to name
        the problem)."""
        if not pin.isNormalized(self.mbm.model, q, UNIT_TOL):  # 0.3 us; NaN fails it too
            check_configuration(self.mbm.model, q)  # says what is wrong
        try:
            plan = self._local.plan
        except AttributeError:
            plan = self._row_plan()
        return plan.partition_at(q, rows, v, rtol, res)

    def evaluate_members(self, family, Q, normals: Mapping[int, np.ndarray] | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
        """``(M (k, nv, nv), A (k, m, nv))`` of the members of a model family, member
        ``i`` at ``Q[i]``.

        Parameters
        ----------
        family : ModelFamily or None
            Its model is this set's (:class:`~roverimpact.models.family.ModelFamily`);
            each member's numbers are written into it before its Pinocchio pass, its
            wheel radii go into its contact rows. None: every member is this set's model
            (k configurations of one model, each with its own ``normals``).
        Q : (k, nq) array_like
        normals : dict, optional
            ``{constraint index: (k, 3) normals}``: a contact whose normal differs from
            member to member (an obstacle face at another angle); the others keep their
            own.

        The loop-closure rows must not depend on the configuration
        (:attr:`~roverimpact.models._assemble.RowPlan.loops_constant`).
        """
        plan = self._row_plan()
        if family is not None and not plan.loops_constant:
            raise ModelError("evaluate_members needs constant loop-closure rows")
        Q = np.ascontiguousarray(np.asarray(Q, dtype=float))
        k = Q.shape[0] if Q.ndim == 2 else -1
        if Q.shape != (k, self.mbm.model.nq) or (family is not None and family.k != k):
            raise ModelError(f"Q must have shape ({k if family is None else family.k}, "
                             f"{self.mbm.model.nq}), got {Q.shape}")
        cn = np.array(np.broadcast_to(plan.c_normal, (k, *plan.c_normal.shape)))
        for ci, n in (normals or {}).items():
            cn[:, plan.constraint_contact[ci]] = n
        if family is None:
            check_configuration(self.mbm.model, Q)
            with self.lock:
                return plan.evaluate_many(Q, c_normal=cn)
        wheels = {w.name: j for j, w in enumerate(self.mbm.wheels)}
        cr = np.array(np.broadcast_to(plan.c_radius, (k, *plan.c_radius.shape)))
        for c, w in enumerate(plan.contact_wheel):
            if w is not None:
                cr[:, c] = family.numbers.wheel_radius[:, wheels[w]]
        with self.lock:
            return plan.evaluate_many(Q, before=family.write, c_normal=cn, c_radius=cr)


def _frame_id(model, name: str) -> int:
    if not model.existFrame(name):
        known = sorted({f.name for f in model.frames})
        raise ModelError(f"unknown frame/body {name!r}; the model has frames {known}")
    return model.getFrameId(name)
