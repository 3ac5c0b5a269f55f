r"""Vectorised assembly of a :class:`~roverimpact.models.kinematics.ConstraintSet`'s rows.

The per-constraint path (``GroundContact.rows`` etc.) is the readable reference; this
module computes the same ``A`` in one compiled pass from the world-frame joint Jacobian
``data.J`` of ``pin.computeJointJacobians`` (the twist of each joint's motion subspace at
the world origin). For a point ``p`` of a body with supporting joints ``S``:

.. math::

    v_p = \big(J_{lin} - [p]_\times J_{ang}\big)\big|_{S}\, v, \qquad
    a = d^T v_p = \big(d^T J_{lin} + (p \times d)^T J_{ang}\big)\big|_{S}

(columns outside ``S`` are zero; ``pin.getFrameJacobian`` applies the same mask). The
contact point of a wheel facing a surface of normal ``n`` is the rim point
``c - r\,\hat d``, ``\hat d`` the unit part of ``n`` orthogonal to the world wheel axis
``a = R\,a_{local}``; the no-slip directions are ``t = a \times n / |a \times n|`` and
``n \times t``. Rows that do not depend on ``q`` (locked joints, linear loop closures) are
stored once.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from numba import njit

# row kinds
_NORMAL, _LONG, _LAT, _CONST = 0, 1, 2, 3
# contact kinds
_WHEEL, _POINT = 0, 1


@njit(cache=True, nogil=True)
def _assemble(J, R, o, c_frame, c_kind, c_vec, c_normal, c_radius, r_contact, r_kind,
              r_const, support, A):  # pragma: no cover - compiled
    """Fill ``A`` (m, nv). ``R`` (F, 3, 3), ``o`` (F, 3): placements of the used frames."""
    nc = c_frame.shape[0]
    nv = J.shape[1]
    P = np.empty((nc, 3))
    T = np.empty((nc, 3))  # no-slip direction a x n / |a x n| (wheels)
    for c in range(nc):
        f = c_frame[c]
        n0, n1, n2 = c_normal[c, 0], c_normal[c, 1], c_normal[c, 2]
        if c_kind[c] == _WHEEL:
            a0 = R[f, 0, 0] * c_vec[c, 0] + R[f, 0, 1] * c_vec[c, 1] + R[f, 0, 2] * c_vec[c, 2]
            a1 = R[f, 1, 0] * c_vec[c, 0] + R[f, 1, 1] * c_vec[c, 1] + R[f, 1, 2] * c_vec[c, 2]
            a2 = R[f, 2, 0] * c_vec[c, 0] + R[f, 2, 1] * c_vec[c, 1] + R[f, 2, 2] * c_vec[c, 2]
            na = n0 * a0 + n1 * a1 + n2 * a2
            d0, d1, d2 = n0 - na * a0, n1 - na * a1, n2 - na * a2
            nd = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if nd < 1e-9:
                d0, d1, d2 = n0, n1, n2
            else:
                d0, d1, d2 = d0 / nd, d1 / nd, d2 / nd
            r = c_radius[c]
            P[c, 0] = o[f, 0] - r * d0
            P[c, 1] = o[f, 1] - r * d1
            P[c, 2] = o[f, 2] - r * d2
            t0, t1, t2 = a1 * n2 - a2 * n1, a2 * n0 - a0 * n2, a0 * n1 - a1 * n0
            nt = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            if nt > 0.0:
                t0, t1, t2 = t0 / nt, t1 / nt, t2 / nt
            T[c, 0], T[c, 1], T[c, 2] = t0, t1, t2
        else:
            x0, x1, x2 = c_vec[c, 0], c_vec[c, 1], c_vec[c, 2]
            for i in range(3):
                P[c, i] = o[f, i] + R[f, i, 0] * x0 + R[f, i, 1] * x1 + R[f, i, 2] * x2
            T[c, 0], T[c, 1], T[c, 2] = 0.0, 0.0, 0.0
    for row in range(A.shape[0]):
        kind = r_kind[row]
        if kind == _CONST:
            for j in range(nv):
                A[row, j] = r_const[row, j]
            continue
        c = r_contact[row]
        n0, n1, n2 = c_normal[c, 0], c_normal[c, 1], c_normal[c, 2]
        if kind == _NORMAL:
            d0, d1, d2 = n0, n1, n2
        elif kind == _LONG:
            d0, d1, d2 = T[c, 0], T[c, 1], T[c, 2]
        else:  # n x t
            t0, t1, t2 = T[c, 0], T[c, 1], T[c, 2]
            d0, d1, d2 = n1 * t2 - n2 * t1, n2 * t0 - n0 * t2, n0 * t1 - n1 * t0
        p0, p1, p2 = P[c, 0], P[c, 1], P[c, 2]
        # p x d
        e0, e1, e2 = p1 * d2 - p2 * d1, p2 * d0 - p0 * d2, p0 * d1 - p1 * d0
        f = c_frame[c]
        for j in range(nv):
            if support[f, j]:
                A[row, j] = (d0 * J[0, j] + d1 * J[1, j] + d2 * J[2, j]
                             + e0 * J[3, j] + e1 * J[4, j] + e2 * J[5, j])
            else:
                A[row, j] = 0.0


class RowPlan:
    """Structure of a constraint set's rows, built once; :meth:`rows` after kinematics."""

    def __init__(self, cs):
        from .kinematics import GroundContact, LockedJoint, LoopClosure, PointContact

        model = cs.mbm.model
        nv = model.nv
        frames: list[int] = []  # distinct frame ids, in first-use order
        contacts = []  # (frame slot, kind, vec, normal, radius)
        rows = []  # (contact, kind, const row)
        self.loop_rows: list[int] = []  # rows of a nonlinear loop closure (per call)
        self._loop_constant = True
        for c, fid in zip(cs.constraints, cs._fids, strict=True):
            if fid is not None and fid not in frames:
                frames.append(fid)
            if isinstance(c, GroundContact):
                ci = len(contacts)
                contacts.append((frames.index(fid), _WHEEL, c.wheel.axis, c.normal,
                                 c.wheel.radius))
                rows.append((ci, _NORMAL, None))
                if c.noslip:
                    rows.append((ci, _LONG, None))
                    if not c.planar:
                        rows.append((ci, _LAT, None))
            elif isinstance(c, PointContact):
                ci = len(contacts)
                if c.wheel is not None:
                    contacts.append((frames.index(fid), _WHEEL, c.wheel.axis, c.normal,
                                     c.wheel.radius))
                else:
                    contacts.append((frames.index(fid), _POINT, c.point, c.normal, 0.0))
                rows.append((ci, _NORMAL, None))
            elif isinstance(c, LockedJoint):
                j = model.joints[model.getJointId(c.joint)]
                for k in range(j.nv):
                    r = np.zeros(nv)
                    r[j.idx_v + k] = 1.0
                    rows.append((-1, _CONST, r))
            elif isinstance(c, LoopClosure):
                loop = cs.mbm.loop_closure
                # a linear closure (constant J) is stored once; others are recomputed
                from ._build import LinearLoopClosure

                Jl = loop(np.asarray(pin.neutral(model)))[1]
                self._loop_constant &= isinstance(loop, LinearLoopClosure)
                for k in range(Jl.shape[0]):
                    self.loop_rows.append(len(rows))
                    rows.append((-1, _CONST, np.array(Jl[k], dtype=float)))
        self.frame_ids = frames
        nf, nc, m = len(frames), len(contacts), len(rows)
        self.c_frame = np.array([c[0] for c in contacts], dtype=np.int64).reshape(nc)
        self.c_kind = np.array([c[1] for c in contacts], dtype=np.int64).reshape(nc)
        self.c_vec = np.array([c[2] for c in contacts], dtype=float).reshape(nc, 3)
        self.c_normal = np.array([c[3] for c in contacts], dtype=float).reshape(nc, 3)
        self.c_radius = np.array([c[4] for c in contacts], dtype=float).reshape(nc)
        self.r_contact = np.array([max(r[0], 0) for r in rows], dtype=np.int64).reshape(m)
        self.r_kind = np.array([r[1] for r in rows], dtype=np.int64).reshape(m)
        self.r_const = np.zeros((m, nv))
        for i, r in enumerate(rows):
            if r[2] is not None:
                self.r_const[i] = r[2]
        self.support = np.zeros((max(nf, 1), nv), dtype=np.bool_)
        for k, fid in enumerate(frames):
            jid = model.frames[fid].parentJoint
            for s in model.supports[jid]:
                if s == 0:
                    continue
                jm = model.joints[s]
                self.support[k, jm.idx_v:jm.idx_v + jm.nv] = True
        self._R = np.zeros((max(nf, 1), 3, 3))
        self._o = np.zeros((max(nf, 1), 3))
        self.m, self.nv = m, nv
        self._cs = cs

    def rows(self, q) -> np.ndarray:
        """A (m, nv) at ``q``; requires ``computeJointJacobians`` and frame placements."""
        data = self._cs.data
        R, o = self._R, self._o
        for k, fid in enumerate(self.frame_ids):
            oMf = data.oMf[fid]
            R[k] = oMf.rotation
            o[k] = oMf.translation
        if not self._loop_constant:
            Jl = self._cs.mbm.loop_closure(q)[1]
            for k, i in enumerate(self.loop_rows):
                self.r_const[i] = Jl[k]
        A = np.empty((self.m, self.nv))
        _assemble(np.asarray(data.J), R, o, self.c_frame, self.c_kind, self.c_vec,
                  self.c_normal, self.c_radius, self.r_contact, self.r_kind, self.r_const,
                  self.support, A)
        return A
